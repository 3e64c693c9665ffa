# SPDX-License-Identifier: MIT
"""Training: RBM/DBN, CNN, boosted stumps, the classical baselines and the CNN export.
Imports the layers below (bindings, data, metrics, formats)."""
