"""How far to trust the model (docs/uncertainty.md, docs/noise_model.md): the covariance of a least
squares or refined model's matrices, and the noise model.
"""

__all__: list[str] = []
