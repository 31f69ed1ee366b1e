"""The recognition session: what a subject is shown, in which order, and how answers are scored.

A newcomer's map of this room:

- :mod:`~experiment.session.stimset`: a stimulus set folder read back (manifest, objects, files).
- :mod:`~experiment.session.schedule`: the protocol and stimulus set drawn into a trial order.
- :mod:`~experiment.session.plan`: a session start checked once and its schedule built once
  (:func:`~experiment.session.plan.plan_session`), for ``Session.open`` and ``session run``.
- :mod:`~experiment.session.scoring`: suggested scores for spoken answers; rater agreement.
- :mod:`~experiment.session.lifecycle`: a subject's session in the trial log, opened or resumed,
  locked, completed and closed; shared with active search (:mod:`experiment.active.session`).
- :mod:`~experiment.session.engine`: :class:`~experiment.session.engine.Session`, one subject's
  position in a saved schedule, and its headless loop.
- :mod:`~experiment.session.status`: the study's status read from its trial log.

Import from the modules themselves: the package re-exports nothing, so that importing one module
does not load the session engine. A schedule's :class:`~experiment.trials.Trial` and
:class:`~experiment.trials.Schedule` live below this room and the trial log, in
:mod:`experiment.trials`.
"""

__all__: list[str] = []
