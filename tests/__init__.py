"""WildScan's tests (a package, so test modules import tests.helpers by name)."""
