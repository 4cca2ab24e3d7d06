"""The paper's study (`tissuebench paper`): its `cases`, the `truth` it grades them against and
the paper's claims judged on it, the `report` (results/README.md) with its `claims`, `common`
parts, the elastic models' `large_deformation` and `divergence` sections and the `truth_section`;
the schemes' observed orders (`convergence`)."""
