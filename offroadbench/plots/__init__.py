"""Every figure of the package, drawn on matplotlib Figure objects with one palette (style.py).

No module here picks a backend or touches pyplot; the caller (the CLI) saves the figures.
"""
