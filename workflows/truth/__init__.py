"""The truth as the workflows use it (SPEC 10; the solver itself is solvers/truth/): `jobs` the
truths computed side by side, `run` what `tissuebench run` says of its runs against the truth,
`report` truth.md, with the large rod's load `sweep` and its `crease`."""
