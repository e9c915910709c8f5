"""All matplotlib code of ema_rig (imported lazily; never imported by ``import ema_rig``)."""
