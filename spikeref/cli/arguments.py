"""What the commands' arguments share: the help formatter, the checks of numbers and of ``--frames``, and the
comma-separated list types."""

from __future__ import annotations

import argparse
import math

from spikeref.cli.errors import CliError

__all__ = ["DefaultsHelpFormatter", "check_int", "check_float", "check_seed", "parse_frames_option", "frames_within",
           "comma_list", "int_list"]


# Zero is a value like any other, never "not given": options left out are None.
class DefaultsHelpFormatter(argparse.ArgumentDefaultsHelpFormatter):
    """argparse's "(default: X)" only where the help does not already say the default, and never "None"."""

    def _get_help_string(self, action):
        text = action.help or ""
        if action.default is None or action.default is False or action.default == argparse.SUPPRESS \
                or "default" in text.lower():
            return text
        if isinstance(action.default, (tuple, list)):  # written as the option takes it: comma-separated
            return f"{text} (default: {','.join(map(str, action.default))})"
        return super()._get_help_string(action)


def check_int(value, flag: str, minimum: int = 1, what: str = "a positive whole number") -> None:
    """Refuse an integer option below ``minimum`` (``None``: not given, nothing to check)."""
    if value is not None and value < minimum:
        raise CliError(f"{flag} must be {what}; got {value}")


def check_float(value, flag: str, positive: bool = True) -> None:
    """Refuse a float option that is not finite, or not > 0 (``positive``) / not ≥ 0."""
    if value is None:
        return
    if not math.isfinite(value) or value < 0 or (positive and value == 0):
        raise CliError(f"{flag} must be a finite number {'>' if positive else '≥'} 0; got {value:g}")


def check_seed(value) -> None:
    check_int(value, "--seed", 0, "a whole number ≥ 0")


def parse_frames_option(text: str | None):
    """``--frames a:b`` (either end may be left out) → ``(a, b)`` with ``None`` for a missing end."""
    if text is None:
        return None, None
    parts = text.split(":")
    if len(parts) != 2:
        raise CliError(f"--frames must look like a:b (frame numbers, b excluded); got {text!r}")
    try:
        return tuple(int(v) if v.strip() else None for v in parts)
    except ValueError:
        raise CliError(f"--frames must look like a:b with integer frame numbers; got {text!r}") from None


def frames_within(text: str | None, avail: range, outside: str) -> range:
    """``--frames``: ``a:b`` (frame numbers, b excluded; a missing end is ``avail``'s) inside ``avail``, or ``N``,
    the first ``N`` frames of ``avail`` (a count past the end is cut to the end); not given (None), all of ``avail``.
    An empty range or one outside ``avail`` is refused, the latter with ``outside`` (formatted with ``start`` and
    ``stop`` of ``avail``)."""
    if text is None:
        return avail
    text = str(text).strip()
    if ":" not in text:
        try:
            n = int(text)
        except ValueError:
            raise CliError(f"--frames must be a:b (frame numbers, b excluded) or a number of frames; "
                           f"got {text!r}") from None
        check_int(n, "--frames", 1, "a positive number of frames")
        return range(avail.start, min(avail.start + n, avail.stop))
    a, b = parse_frames_option(text)
    a = avail.start if a is None else a
    b = avail.stop if b is None else b
    if a >= b:
        raise CliError(f"--frames {a}:{b}: an empty range (the first frame must come before the end, which is "
                       f"excluded; {outside.format(start=avail.start, stop=avail.stop)})")
    if a < avail.start or b > avail.stop:
        raise CliError(f"--frames {a}:{b}: {outside.format(start=avail.start, stop=avail.stop)}")
    return range(a, b)


def comma_list(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def int_list(text: str) -> tuple[int, ...]:
    try:
        return tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated whole numbers of planes; got {text!r}") from None
