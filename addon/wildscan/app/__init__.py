"""What each command does, as plain functions with typed arguments (no argparse)."""
