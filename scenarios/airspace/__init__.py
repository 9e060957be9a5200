"""Airspace-scale fences: the synthetic city park generator and its GeoJSON files (see ``generate.py``)."""
