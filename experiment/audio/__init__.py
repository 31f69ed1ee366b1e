"""The subject's voice: per-trial recordings of the spoken answer and their voice onset.

Optional: needs the ``audio`` extra (sounddevice, soundfile). See :mod:`experiment.audio.voice`
for the onset method and :mod:`experiment.audio.recorder` for where files and rows go.
"""

from experiment.audio.devices import Microphone, ScriptedMicrophone, open_microphone
from experiment.audio.recorder import TrialAudio, audio_dir, read_audio_rows
from experiment.audio.voice import voice_onset_s

__all__ = [
    "Microphone",
    "ScriptedMicrophone",
    "open_microphone",
    "TrialAudio",
    "audio_dir",
    "read_audio_rows",
    "voice_onset_s",
]
