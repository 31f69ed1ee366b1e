"""The operators' consoles: Textual apps at the operator's terminal, beside the subject's screen.

- :mod:`experiment.console.recognition`: :class:`OperatorConsole`, which runs the recognition
  study trial by trial (keys, undo and why nothing logged is lost are described there).
- :mod:`experiment.console.launch`: :func:`run_console` and :func:`make_display`, which open the
  subject's screen and run that console.
- :mod:`experiment.console.active`: the console of an active search with a person searching.
- :mod:`experiment.console.rescoring`: :class:`ScoringApp`, a second rater's blind scoring.
- :mod:`experiment.console.layout`: the layout, preview and app base the consoles share.
- :mod:`experiment.console.keys`: the score keys.
- :mod:`experiment.console.logfile`: log lines go to the session log while a console runs.

The subject's screen is a :class:`~experiment.interfaces.Display`: by default the presenter
process (:class:`experiment.presentation.process.RemoteDisplay`), in tests a headless twin.
"""

from experiment.console.keys import SCORE_KEYS
from experiment.console.launch import make_display, run_console
from experiment.console.layout import CONSOLE_CSS, console_layout, preview_text
from experiment.console.logfile import logs_to_file, session_log_path
from experiment.console.recognition import ConsoleResult, OperatorConsole
from experiment.console.rescoring import ScoringApp

__all__ = [
    "SCORE_KEYS",
    "CONSOLE_CSS",
    "console_layout",
    "OperatorConsole",
    "ScoringApp",
    "ConsoleResult",
    "preview_text",
    "make_display",
    "run_console",
    "session_log_path",
    "logs_to_file",
]
