"""Files WildScan writes and reads (numpy only): PLY + JSON sidecar, and atomic outputs."""
