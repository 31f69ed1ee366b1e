"""The ``confocal`` sub-commands of experiment/: one typer module per command.

A command module declares its options, checks them and calls the work, which lives in the library
rooms below it (:mod:`experiment.session`, :mod:`experiment.presentation`, :mod:`experiment.viewer`,
:mod:`experiment.active`, ...). Nothing in those rooms imports a command module, so the rooms
import each other one way only. The root :mod:`experiment.cli` lists the modules by name in its
``SUBCOMMANDS`` table and imports one only when its command runs.

- :mod:`experiment.commands.session`: ``confocal session run | status | export``.
- :mod:`experiment.commands.run_options`: the options and checks ``session run`` and
  ``active run`` share.
- :mod:`experiment.commands.present`: ``confocal present``.
- :mod:`experiment.commands.score`: ``confocal score`` (a second rater, blind to the first).
- :mod:`experiment.commands.view`: ``confocal view``.
- :mod:`experiment.commands.active`: ``confocal active``.
"""

__all__: list[str] = []
