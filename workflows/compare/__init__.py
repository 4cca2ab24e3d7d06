"""Grading a candidate against a reference or the truth (`tissuebench compare`, and every row of
the leaderboard): `grading` the three metrics and their figures, `contact` the needle force and
interpenetration of a contact case (SPEC 12), `posing` a benchmark posed for another simulator
(`tissuebench export`)."""
