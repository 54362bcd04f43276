"""Figures, archive summaries and the HTML report (matplotlib and jinja2 are imported here)."""
