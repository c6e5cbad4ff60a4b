"""The world cache: what a dataset worker builds of a world, kept on disk for every later run
and worker (worlds.py: what is kept; store.py: the files, verified, atomic, capped; key.py:
the keys, with a hash of the code; config.py: where, how big, the command line's options)."""
