"""Pictures (matplotlib, an optional extra, imported lazily by whoever draws)."""
