# SPDX-License-Identifier: MIT
"""vd-adapt: fit the shipped networks to a user's camera from its own frames (docs/adapt.md).
`python3 -m vdtools.adapt --help`; the console script `vd-adapt` runs the same main()."""


def main(argv=None):
    from vdtools.adapt.cli import main as _main
    return _main(argv)
