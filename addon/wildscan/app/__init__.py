"""What each command does, as plain functions with typed arguments (no argparse): the
`wildscan` command line (cli/), the Blender scripts and the add-on's operators (ui/) all
call these, so the same request gives the same world and the same points everywhere."""
