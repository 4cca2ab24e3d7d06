"""The leaderboard page's template, stylesheet and script (package data, read by page.py)."""
