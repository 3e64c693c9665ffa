# SPDX-License-Identifier: MIT
"""Model formats and integer references: the .vdm kinds (DBN, CNN, boosted), quantisation,
C-array export and the bit-exact numpy references of the C networks. Imports bindings and data."""
