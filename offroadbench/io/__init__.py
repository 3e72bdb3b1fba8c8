"""File input and output: the only package (with the CLI) that reads and writes files."""
