"""Presentation: figures (matplotlib, PNG), the HTML report and the demo."""
