"""The real-time frontier (SPEC 11, `tissuebench frontier`): `runs` the schemes' runs graded
against the truth, `report` its table and figure."""
