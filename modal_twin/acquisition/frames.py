"""Raw blocks (volts) -> frames in SI units, channel by channel from the channel map."""

from __future__ import annotations

from collections.abc import Mapping

from modal_twin.acquisition.calibration import calibrate
from modal_twin.channels import ChannelSpec
from modal_twin.signal_block import SignalBlock

__all__ = ["frame_from_raw"]


def frame_from_raw(raw: SignalBlock, channels: Mapping[str, ChannelSpec]
                   ) -> tuple[SignalBlock | None, list[str]]:
    """Calibrate the channels of ``raw`` that the map knows; name the others.

    Returns
    -------
    frame : SignalBlock or None
        The known channels in SI units (:func:`~modal_twin.acquisition.calibration.calibrate`
        with each channel's sensitivity), same indices and stamp; None if none is known.
    unknown : list of str
        Channels of ``raw`` missing from the map (dropped).
    """
    keep = [c for c in raw.channel_names if c in channels]
    unknown = [c for c in raw.channel_names if c not in channels]
    if not keep:
        return None, unknown
    block = raw.select(keep)
    si = calibrate(block.data, [channels[c].sensitivity for c in keep])
    return SignalBlock(block.channel_names, raw.fs_hz, raw.first_index, si, raw.stamp_ns,
                       "acquisition"), unknown
