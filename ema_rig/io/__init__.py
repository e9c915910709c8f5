"""File input/output.

``ema_rig.io.uff`` reads and writes dataset 58/58b (FRFs; every other dataset is listed);
``time_data`` turns its time histories into force and response records; ``geometry`` reads nodes
and trace lines (15, 2411, 82) and ``uff55`` writes mode shapes (55), both through pyuff;
``units`` is the one unit-label grammar (``parse_unit_label``) every reader uses.
"""
