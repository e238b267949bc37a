"""World data (MJCF files and route sidecars), installed as the ``sim.worlds`` package so that
``importlib.resources`` finds it in editable and regular installs alike. Regenerate with
``python -m sim.arenas worlds``."""
