"""Sub-commands of ``ema-rig``: one module each with ``add_arguments(parser)`` and ``run(args)``.

Modules here import only argparse at import time; the numeric work is imported inside ``run``.
"""
