"""File input/output. ``ema_rig.io.uff`` is the only module that touches UFF files."""
