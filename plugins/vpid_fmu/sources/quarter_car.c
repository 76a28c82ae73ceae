/* A quarter car as an FMU (FMI 2.0 co-simulation and model exchange, or FMI 3.0
 * co-simulation with -DFMI3): the example model of vpid-bench's problem=fmu and of its tests.
 *
 * Model (SI units), as problem=ride_quarter with ct = 0:
 *   ms zs'' = -cs (zs' - zu') - ks (zs - zu)
 *   mu zu'' =  cs (zs' - zu') + ks (zs - zu) - kt (zu - h)
 * Input h (m, the road height); outputs zsdd, zudd (m/s^2) and stroke = zs - zu (m).
 *
 * Co-simulation: doStep integrates by RK4 on internal steps of at most 1e-4 s with the input
 * linear over the step when fmi2SetRealInputDerivatives gave its slope (canInterpolateInputs),
 * else held. Outputs at a communication point use the input at that point.
 *
 * Test variants: -DCRASH writes through a null pointer in the first doStep at t >= 0.5 s;
 * -DHANG spins for ever there. -DGUID="..." sets the token the binary accepts.
 */
#include <math.h>
#include <stdlib.h>
#include <string.h>

#ifndef GUID
#define GUID "{8c4e810f-3df3-4a00-8276-176fa3c9f000}"
#endif

enum { V_MS, V_MU, V_KS, V_CS, V_KT, V_H, V_ZSDD, V_ZUDD, V_STROKE,
       V_ZS, V_ZU, V_VS, V_VU, V_DZS, V_DZU, V_DVS, V_DVU, NV };

typedef struct {
    double v[NV];    /* every variable by value reference */
    double hd;       /* the input's slope over the current step (m/s) */
    double time;
    int interpolate;
} Model;

static const double START[NV] = {250.0, 37.5, 15825.0, 1500.0, 163250.0};

static void reset_model(Model *m) {
    memset(m, 0, sizeof *m);
    memcpy(m->v, START, sizeof START);
}

static void derivatives(const Model *m, const double x[4], double h, double dx[4]) {
    const double *p = m->v;
    double fs = p[V_CS] * (x[2] - x[3]) + p[V_KS] * (x[0] - x[1]);
    dx[0] = x[2];
    dx[1] = x[3];
    dx[2] = -fs / p[V_MS];
    dx[3] = (fs - p[V_KT] * (x[1] - h)) / p[V_MU];
}

/* the derived variables (derivatives and outputs) from the states and the input */
static void update(Model *m) {
    double dx[4];
    derivatives(m, &m->v[V_ZS], m->v[V_H], dx);
    m->v[V_DZS] = dx[0]; m->v[V_DZU] = dx[1]; m->v[V_DVS] = dx[2]; m->v[V_DVU] = dx[3];
    m->v[V_ZSDD] = dx[2]; m->v[V_ZUDD] = dx[3];
    m->v[V_STROKE] = m->v[V_ZS] - m->v[V_ZU];
}

static void fault(double t) {
    (void)t;
#ifdef CRASH
    if (t >= 0.5) { volatile int *p = NULL; *p = 1; }
#endif
#ifdef HANG
    if (t >= 0.5) { volatile int spin = 1; while (spin) { } }
#endif
}

/* one communication step of size H from m->time: RK4 on n equal sub-steps */
static void step(Model *m, double H) {
    int n = (int)ceil(H / 1e-4 - 1e-9);
    if (n < 1) n = 1;
    double dt = H / n, h0 = m->v[V_H], slope = m->interpolate ? m->hd : 0.0;
    double *x = &m->v[V_ZS];
    fault(m->time);
    for (int i = 0; i < n; i++) {
        double t0 = i * dt, k1[4], k2[4], k3[4], k4[4], y[4];
        derivatives(m, x, h0 + slope * t0, k1);
        for (int j = 0; j < 4; j++) y[j] = x[j] + 0.5 * dt * k1[j];
        derivatives(m, y, h0 + slope * (t0 + 0.5 * dt), k2);
        for (int j = 0; j < 4; j++) y[j] = x[j] + 0.5 * dt * k2[j];
        derivatives(m, y, h0 + slope * (t0 + 0.5 * dt), k3);
        for (int j = 0; j < 4; j++) y[j] = x[j] + dt * k3[j];
        derivatives(m, y, h0 + slope * (t0 + dt), k4);
        for (int j = 0; j < 4; j++) x[j] += dt / 6.0 * (k1[j] + 2 * k2[j] + 2 * k3[j] + k4[j]);
    }
    m->time += H;
    /* the input is now where its slope took it (held: unchanged); the outputs see it */
    m->v[V_H] = h0 + slope * H;
    update(m);
}

static int get(Model *m, const unsigned int vr[], size_t n, double value[]) {
    update(m);
    for (size_t i = 0; i < n; i++) {
        if (vr[i] >= NV) return 0;
        value[i] = m->v[vr[i]];
    }
    return 1;
}

static int set(Model *m, const unsigned int vr[], size_t n, const double value[]) {
    for (size_t i = 0; i < n; i++) {
        if (vr[i] > V_H) return 0;  /* parameters and the input only */
        m->v[vr[i]] = value[i];
    }
    return 1;
}

#ifndef FMI3
/* ------------------------------------------------------------------ FMI 2.0 */
#include "fmi2Functions.h"

#define M ((Model *)c)
#define OK(cond) ((cond) ? fmi2OK : fmi2Error)

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) {
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                              fmi2String resources, const fmi2CallbackFunctions *cb,
                              fmi2Boolean visible, fmi2Boolean logging) {
    if (guid == NULL || strcmp(guid, GUID) != 0) return NULL;
    Model *m = calloc(1, sizeof(Model));
    if (m) reset_model(m);
    return m;
}

void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDefined, fmi2Real tol,
                               fmi2Real start, fmi2Boolean stopDefined, fmi2Real stop) {
    M->time = start;
    return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { update(M); return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { reset_model(M); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real v[]) {
    return OK(get(M, vr, n, v));
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                       const fmi2Real v[]) {
    for (size_t i = 0; i < n; i++) if (vr[i] == V_H) M->hd = 0.0;  /* a new value: no slope yet */
    M->interpolate = 0;
    return OK(set(M, vr, n, v));
}

#define UNSUPPORTED(decl) decl { return fmi2Error; }
UNSUPPORTED(fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]))
UNSUPPORTED(fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]))
UNSUPPORTED(fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]))
UNSUPPORTED(fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]))
UNSUPPORTED(fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]))
UNSUPPORTED(fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]))
UNSUPPORTED(fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s))
UNSUPPORTED(fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s))
UNSUPPORTED(fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s))
UNSUPPORTED(fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n))
UNSUPPORTED(fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n))
UNSUPPORTED(fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s))
UNSUPPORTED(fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[], size_t nu, const fmi2ValueReference z[], size_t nz, const fmi2Real dv[], fmi2Real dz[]))
UNSUPPORTED(fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer o[], fmi2Real v[]))
UNSUPPORTED(fmi2Status fmi2CancelStep(fmi2Component c))
UNSUPPORTED(fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v))
UNSUPPORTED(fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v))
UNSUPPORTED(fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v))
UNSUPPORTED(fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v))
UNSUPPORTED(fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v))

/* co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                                       const fmi2Integer order[], const fmi2Real v[]) {
    for (size_t i = 0; i < n; i++) {
        if (vr[i] != V_H || order[i] != 1) return fmi2Error;
        M->hd = v[i];
        M->interpolate = 1;
    }
    return fmi2OK;
}
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real H, fmi2Boolean noPrior) {
    if (!(H > 0)) return fmi2Error;
    M->time = t;
    step(M, H);
    M->interpolate = 0;
    return fmi2OK;
}

/* model exchange */
fmi2Status fmi2EnterEventMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *info) {
    memset(info, 0, sizeof *info);
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noPrior,
                                       fmi2Boolean *enterEvent, fmi2Boolean *terminate) {
    *enterEvent = fmi2False;
    *terminate = fmi2False;
    return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { fault(t); M->time = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    if (n != 4) return fmi2Error;
    memcpy(&M->v[V_ZS], x, 4 * sizeof(double));
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    if (n != 4) return fmi2Error;
    derivatives(M, &M->v[V_ZS], M->v[V_H], dx);
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    return OK(n == 0);
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    if (n != 4) return fmi2Error;
    memcpy(x, &M->v[V_ZS], 4 * sizeof(double));
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    for (size_t i = 0; i < n; i++) x[i] = 1.0;
    return OK(n == 4);
}

#else
/* ------------------------------------------------------------------ FMI 3.0 */
#include "fmi3Functions.h"

#define M ((Model *)instance)
#define OK(cond) ((cond) ? fmi3OK : fmi3Error)

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean on, size_t n,
                               const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String resources,
        fmi3Boolean visible, fmi3Boolean logging, fmi3Boolean eventMode, fmi3Boolean early,
        const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
        fmi3LogMessageCallback log, fmi3IntermediateUpdateCallback update_cb) {
    if (token == NULL || strcmp(token, GUID) != 0) return NULL;
    Model *m = calloc(1, sizeof(Model));
    if (m) reset_model(m);
    return m;
}
void fmi3FreeInstance(fmi3Instance instance) { free(instance); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean tolDefined,
        fmi3Float64 tol, fmi3Float64 start, fmi3Boolean stopDefined, fmi3Float64 stop) {
    M->time = start;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) { update(M); return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance instance) { return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance instance) { reset_model(M); return fmi3OK; }
fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                          fmi3Float64 v[], size_t nv) {
    return OK(n == nv && get(M, vr, n, v));
}
fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                          const fmi3Float64 v[], size_t nv) {
    return OK(n == nv && set(M, vr, n, v));
}
fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 H, fmi3Boolean noPrior,
                      fmi3Boolean *event, fmi3Boolean *terminate, fmi3Boolean *early,
                      fmi3Float64 *last) {
    if (!(H > 0)) return fmi3Error;
    M->time = t;
    M->interpolate = 0;
    step(M, H);
    *event = fmi3False; *terminate = fmi3False; *early = fmi3False; *last = t + H;
    return fmi3OK;
}
#endif
