"""The frequency domain of (10): every field ∝ e^{st}. The harmonic response at s = 2πif (`harmonic`) and the
coupled modes of the fluid–structure system (`pencil`, `modes`); beside `timestepping`, on the same spaces and
forms."""
