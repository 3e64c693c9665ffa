# SPDX-License-Identifier: MIT
"""Detection metrics (IoU matching, average precision, DET curves) shared by training and
evaluation. Imports nothing else from vdtools."""
