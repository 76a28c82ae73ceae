"""Any FMU (FMI 2.0 or 3.0, co-simulation or model exchange) as a vpid-bench problem
(``problem=fmu``): its parameters identified from a record it should reproduce. See
:mod:`.problem` and docs/fmu.md."""
