"""Regularized estimation for short records (docs/regularization.md): impulse responses with a
kernel prior (TC, DC, SS) whose hyperparameters maximize the marginal likelihood."""

__all__: list[str] = []
