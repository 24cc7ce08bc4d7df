"""Figures and animations (matplotlib, headless), imported on demand only."""
