"""The leaderboard (`tissuebench leaderboard`), all of it in one package; the command
(workflows/commands/leaderboard.py) only parses its arguments and calls `build.main`.

- `record`: leaderboard.json, read and validated row by row (type and range) before anything
  is replaced, and written;
- `users`: the users' compare folders, each checked against its case, its own manifest (an
  edited summary is left out with one line; the manifest guards against accidents and is no
  signature), its links and its series' hashes;
- `runs`: our runs and every simulator's on a case (`--rerun`);
- `grading`: every row graded against the case's truth, with its error budget (SPEC 10), and
  each user's row graded from its series (against the case's reference too): no number of
  a user's folder is believed;
- `rows` (`ranking` re-exports it): the Row, reading outside rows, the checks of a compare
  summary, the Pareto front;
- `page`: results/leaderboard/index.html, one self-contained page (inline SVG and a little
  JavaScript, no download);
- `document`: leaderboard.md, the one-screen summary per case; `figures`: the PNGs;
- `contact`: a contact case's force error and interpenetration columns (SPEC 12), ours',
  the simulators' and the users', graded against the truth's force where it is here;
  `force_figure`: its needle force against time (CASE-force.png);
- `build`: the whole command, its outputs staged and moved into place as one set.

The cases themselves are BOARDS (workflows/leaderboard/boards.py).
"""
