"""The ``mggp`` command line: one module per group of subcommands.

Typical use::

    from mggp.cli.app import main
    main(["fit", "data.csv", "--out", "m.json"])

Modules: :mod:`~mggp.cli.app` (the parser, ``estimate``, ``simulate`` and
the helpers every subcommand shares), :mod:`~mggp.cli.fit`,
:mod:`~mggp.cli.diagnose`, :mod:`~mggp.cli.compensate` and
:mod:`~mggp.cli.quasistatic`.
"""


def __getattr__(name):        # the names of the former module mggp.cli, for one release
    from narx._moved import moved_attribute
    return moved_attribute(__name__, "mggp.cli.app", name)
