"""Figures and the animation, drawn from results (plots never solve)."""
