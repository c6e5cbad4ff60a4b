"""Ray backends behind one interface (core/backend.py RayBackend; what they share: base.py)."""
