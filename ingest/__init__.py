"""Point cloud → ground model → tiles → database."""
