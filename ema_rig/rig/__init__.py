"""The rig: 3DOF model, inversion of the housing mode for k_TB, mode matching, Hertz reference."""
