"""A PyTorch example over a WildScan dataset (not part of the wildscan package).

data.py reads a dataset and projects its scans into range images with numpy alone (the
tests run it without torch); dataset.py wraps it as a torch Dataset; train.py trains a
small RangeNet-style network. See examples/README.md.
"""
