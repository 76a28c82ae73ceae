/* The C loop of benchmarks/bench_fmu.py: one FMI 2.0 co-simulation FMU's binary driven from C
 * over a record's inputs, as vpid-bench's compiled loop drives it (reset, set up, start values,
 * initialise, then per sample: input, its slope, doStep, outputs). Prints the median of the
 * per-simulation wall times in seconds.
 *
 * usage: fmu_c_loop LIB GUID INPUT.bin N DT REPEATS VR_IN VR_OUT1 VR_OUT2 */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment e, fmi2String n, fmi2Status s, fmi2String c,
                   fmi2String m, ...) {}

static double now(void) {
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + 1e-9 * ts.tv_nsec;
}

static int cmp(const void *a, const void *b) {
    double x = *(const double *)a, y = *(const double *)b;
    return (x > y) - (x < y);
}

#define LOAD(name) fmi2##name##TYPE *name = (fmi2##name##TYPE *)dlsym(lib, "fmi2" #name)

int main(int argc, char **argv) {
    if (argc != 10) { fprintf(stderr, "usage\n"); return 2; }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "%s\n", dlerror()); return 1; }
    LOAD(Instantiate); LOAD(SetupExperiment); LOAD(EnterInitializationMode);
    LOAD(ExitInitializationMode); LOAD(Reset); LOAD(SetReal); LOAD(GetReal);
    LOAD(SetRealInputDerivatives); LOAD(DoStep);
    int n = atoi(argv[4]), reps = atoi(argv[6]);
    double dt = atof(argv[5]);
    double *u = malloc(n * sizeof(double)), *y = malloc(2 * n * sizeof(double));
    FILE *f = fopen(argv[3], "rb");
    if (!f || fread(u, sizeof(double), n, f) != (size_t)n) { fprintf(stderr, "input\n"); return 1; }
    fclose(f);
    fmi2ValueReference vin = atoi(argv[7]), vout[2] = {atoi(argv[8]), atoi(argv[9])};
    fmi2ValueReference vpar[4] = {0, 1, 2, 3};
    double par[4] = {280.0, 33.0, 17000.0, 1300.0};
    fmi2Integer order = 1;
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = Instantiate("c", fmi2CoSimulation, argv[2], "", &cb, 0, 0);
    if (!c) { fprintf(stderr, "instantiate\n"); return 1; }
    double *times = malloc(reps * sizeof(double)), sum = 0;
    for (int r = 0; r < reps; r++) {
        double t0 = now();
        Reset(c);
        SetupExperiment(c, 0, 0.0, 0.0, 1, (n - 1) * dt);
        SetReal(c, vpar, 4, par);
        EnterInitializationMode(c);
        SetReal(c, &vin, 1, &u[0]);
        ExitInitializationMode(c);
        GetReal(c, vout, 2, &y[0]);
        for (int k = 0; k < n - 1; k++) {
            double du = (u[k + 1] - u[k]) / dt;
            SetReal(c, &vin, 1, &u[k]);
            SetRealInputDerivatives(c, &vin, 1, &order, &du);
            if (DoStep(c, k * dt, dt, fmi2True) > fmi2Warning) { fprintf(stderr, "step\n"); return 1; }
            SetReal(c, &vin, 1, &u[k + 1]);
            GetReal(c, vout, 2, &y[2 * (k + 1)]);
        }
        times[r] = now() - t0;
        sum += y[2 * (n - 1)];
    }
    qsort(times, reps, sizeof(double), cmp);
    printf("%.9f %.17g\n", times[reps / 2], sum / reps);
    return 0;
}
