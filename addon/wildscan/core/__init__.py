"""Numpy-only core of WildScan. Nothing under this package may import bpy."""
