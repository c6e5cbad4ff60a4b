"""Files WildScan writes and reads (numpy only): PLY + JSON sidecar, SemanticKITTI, LAS, and
atomic outputs; each format module turns scan data into the bytes of one format."""
