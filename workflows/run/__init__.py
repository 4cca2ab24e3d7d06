"""A case's run (`tissuebench run`, and every feature that runs a case): the case posed and
checked (`case`, `checks`), its phases timed (`phases`), its readings, and its figures (`figures`
and the model figures it draws, in one `style`)."""
