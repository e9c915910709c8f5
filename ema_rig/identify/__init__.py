"""Modal identification: PolyMAX (pLSCF), stabilization, automatic selection, LSFD."""
