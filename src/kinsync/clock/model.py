"""The clock model: a local acquisition clock mapped to GPS time (SPEC section 6).

``t_gps_s = reference_gps_s + (t_local_s - reference_local_s) * (1 + drift_ppm * 1e-6)``

(GPS time: continuous seconds since 1980-01-06T00:00:00, SPEC section 1). ``drift_ppm
> 0`` means the local clock runs slow: one local second lasts ``1 + drift_ppm * 1e-6``
GPS seconds. ``reference_local_s`` is the local time of the first good pulse and
``reference_gps_s`` the fitted GPS time of that instant; ``offset_s = reference_gps_s
- reference_local_s`` is the clock offset there. A piecewise model also interpolates
linearly between consecutive good pulses, passing exactly through them; outside their
span it refuses by default (`ClockModel.apply`). `kinsync.clock.fit` makes one from
PPS and ZDA logs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, Literal

import numpy as np

from kinsync._arrays import ReadOnlyArrays, readonly_array
from kinsync._typing import ArrayLike, BoolArray, FloatArray
from kinsync._unix_time import check_not_future
from kinsync._validate import finite_number, time_array, time_number
from kinsync.errors import InputError, OutsideSpanError

__all__ = [
    "CLOCK_FORMULA",
    "EXTRAPOLATION_SPANS",
    "OUTSIDE_POLICIES",
    "PIECEWISE_CLOCK_FORMULA",
    "ClockModel",
    "OutsidePolicy",
]

OutsidePolicy = Literal["extrapolate", "raise", "nan"]
"""What `ClockModel.apply` does with a time outside the span of the fitted pulses."""


OUTSIDE_POLICIES: tuple[OutsidePolicy, ...] = ("extrapolate", "raise", "nan")

EXTRAPOLATION_SPANS = 1.0
"""How far beyond either end of the fitted span a linear model is trusted by default
(`ClockModel.extrapolation_limits_s`), in lengths of that span: a 10-minute fit maps
times from 10 minutes before its first pulse to 10 minutes after its last. A time much
further out is most often on another clock or time base (boot time against Unix time),
where the line gives a confident, wrong date."""


CLOCK_FORMULA = (
    "t_gps_s = reference_gps_s + (t_local_s - reference_local_s) * (1 + drift_ppm * 1e-6)"
)
"""The linear clock model, as written in model files and JSON output."""

PIECEWISE_CLOCK_FORMULA = (
    "t_gps_s = knots_gps_s[k] + (t_local_s - knots_local_s[k]) * (knots_gps_s[k+1] - "
    "knots_gps_s[k]) / (knots_local_s[k+1] - knots_local_s[k]) where knots_local_s[k] <= "
    "t_local_s <= knots_local_s[k+1] (the good pulses); outside span_local_s, when "
    f"extrapolated: {CLOCK_FORMULA}"
)
"""The piecewise-linear clock model, as written in model files and JSON output."""

MODEL_KIND = "kinsync clock model"
"""The ``kind`` a model file states (`ClockModel.as_document`)."""

MODEL_VERSION = 1
"""The ``version`` of the model file layout this kinsync writes and reads."""

GPS_TIME_SPAN_S = (0.0, 3_786_480_018.0)
"""GPS times a model file may hold (s): from the GPS epoch (1980-01-06T00:00:00) to
2100-01-01T00:00:00 UTC, the span of coordinate epochs kinsync accepts. A value outside
is not a survey's GPS time (a Unix time, seconds of week gone negative, an edit)."""


def _finite_times(
    t_local_s: ArrayLike, name: str, clock: Literal["gps", "local"] = "local"
) -> FloatArray:
    t = time_array(t_local_s, name, clock=clock)
    bad = ~np.isfinite(t)
    if np.any(bad):
        first = int(np.flatnonzero(bad.reshape(-1))[0])
        msg = f"{name}: value at index {first} is not finite; every time must be a number"
        raise InputError(msg)
    return t


@dataclass(frozen=True, eq=False)
class ClockModel(ReadOnlyArrays):
    """Mapping of a local clock to GPS time (linear, optionally piecewise-linear).

    ``t_gps_s = reference_gps_s + (t_local_s - reference_local_s) * (1 + drift_ppm * 1e-6)``

    Attributes
    ----------
    reference_local_s : float
        Local time of the reference instant (s, local clock); a fit sets it to the
        first good pulse.
    reference_gps_s : float
        GPS time of the reference instant (s since the GPS epoch), full precision.
    drift_ppm : float
        Rate error of the local clock (ppm); > 0: the local clock runs slow.
    span_local_s : tuple of (float, float)
        Local times of the first and last pulse the model was fitted on.
    knots_local_s, knots_gps_s : ndarray, shape (K,), or None
        Piecewise-linear model: local and GPS times of the good pulses (K >= 2,
        strictly increasing), interpolated linearly inside the span; None for the
        linear model.

    Raises
    ------
    InputError
        A time that is not a finite float64-precise number (a float32 GPS time is held
        in steps of 128 s), a GPS time (``reference_gps_s``, the knots) outside
        `GPS_TIME_SPAN_S` (the model file reader refuses those, so a model that can be
        written can be read back) or after today (a Unix time, 10 years late), a drift
        that stops the clock, inconsistent knots.

    Notes
    -----
    Models compare by identity (``==`` is ``is``): two fits of the same log are two
    models; compare their fields (or `as_document`) to tell whether they agree.
    """

    reference_local_s: float
    reference_gps_s: float
    drift_ppm: float
    span_local_s: tuple[float, float]
    knots_local_s: FloatArray | None = None
    knots_gps_s: FloatArray | None = None

    def __post_init__(self) -> None:
        local = time_number(self.reference_local_s, "clock reference_local_s", clock="local")
        object.__setattr__(self, "reference_local_s", local)
        gps = time_number(self.reference_gps_s, "clock reference_gps_s", clock="gps")
        object.__setattr__(self, "reference_gps_s", gps)
        _check_gps_times([self.reference_gps_s], "reference_gps_s", "clock")
        object.__setattr__(self, "drift_ppm", finite_number(self.drift_ppm, "clock drift_ppm"))
        if abs(self.drift_ppm) >= 1e6:
            msg = f"clock drift_ppm: {self.drift_ppm} ppm would stop or reverse the clock"
            raise InputError(msg)
        span = self.span_local_s
        if not isinstance(span, Sequence | np.ndarray) or len(span) != 2:
            msg = f"clock span_local_s: expected two times (first, last), got {span!r}"
            raise InputError(msg)
        lo = time_number(span[0], "clock span_local_s[0]", clock="local")
        hi = time_number(span[1], "clock span_local_s[1]", clock="local")
        if hi < lo:
            msg = f"clock span_local_s: last time {hi} is before first time {lo}"
            raise InputError(msg)
        object.__setattr__(self, "span_local_s", (lo, hi))
        if (self.knots_local_s is None) != (self.knots_gps_s is None):
            msg = "clock knots: give both knots_local_s and knots_gps_s, or neither"
            raise InputError(msg)
        if self.knots_local_s is not None and self.knots_gps_s is not None:
            kl = _finite_times(self.knots_local_s, "clock knots_local_s")
            kg = _finite_times(self.knots_gps_s, "clock knots_gps_s", "gps")
            if kl.ndim != 1 or kl.shape != kg.shape or len(kl) < 2:
                msg = (
                    "clock knots: knots_local_s and knots_gps_s must be 1-D, of one length, "
                    f"with at least 2 knots; got shapes {kl.shape} and {kg.shape}"
                )
                raise InputError(msg)
            if np.any(np.diff(kl) <= 0.0) or np.any(np.diff(kg) <= 0.0):
                msg = "clock knots: knot times must be strictly increasing"
                raise InputError(msg)
            if (float(kl[0]), float(kl[-1])) != (lo, hi):
                msg = (
                    f"clock knots: the knots span [{kl[0]!r}, {kl[-1]!r}] but span_local_s is "
                    f"[{lo!r}, {hi!r}]"
                )
                raise InputError(msg)
            _check_gps_times(kg[[0, -1]], "knots_gps_s", "clock")  # increasing: the ends tell
            object.__setattr__(self, "knots_local_s", readonly_array(kl))
            object.__setattr__(self, "knots_gps_s", readonly_array(kg))

    @property
    def offset_s(self) -> float:
        """Clock offset at the reference: ``reference_gps_s - reference_local_s`` (s)."""
        return self.reference_gps_s - self.reference_local_s

    @property
    def offset_resolution_s(self) -> float:
        """Step between the offsets the model can hold (s).

        The float64 spacing of the larger of its reference times (2.4e-7 s for a GPS
        time from 2004 on): digits of `offset_s` below it say nothing.
        """
        return max(math.ulp(self.reference_gps_s), math.ulp(self.reference_local_s))

    @property
    def time_decimals(self) -> int:
        """Decimals of a second worth printing for its reference times and offset.

        Those above `offset_resolution_s`, at most 9: 6 (1 us) for a GPS time from 2004
        on, whose float64 cannot say 1479384018.0000002 s from 1479384018 s.
        """
        return min(9, max(0, math.floor(-math.log10(self.offset_resolution_s))))

    @property
    def formula(self) -> str:
        """The model as a formula: `CLOCK_FORMULA`, or `PIECEWISE_CLOCK_FORMULA`."""
        return PIECEWISE_CLOCK_FORMULA if self.piecewise else CLOCK_FORMULA

    @property
    def piecewise(self) -> bool:
        """True when the model interpolates between pulses."""
        return self.knots_local_s is not None

    def linear(self) -> ClockModel:
        """The same model without the piecewise knots."""
        return ClockModel(
            reference_local_s=self.reference_local_s,
            reference_gps_s=self.reference_gps_s,
            drift_ppm=self.drift_ppm,
            span_local_s=self.span_local_s,
        )

    def inside_span(self, t_local_s: ArrayLike) -> BoolArray:
        """Which local times lie within the span of the fitted pulses (ends included).

        Parameters
        ----------
        t_local_s : array_like, shape (...)
            Local clock times (s), finite.

        Returns
        -------
        ndarray of bool, shape (...)
            True where ``span_local_s[0] <= t <= span_local_s[1]``.

        Raises
        ------
        InputError
            Times that are not numbers of seconds (datetime64, text, a float dtype too
            coarse for the times) or not finite, naming the first such index.
        """
        t = _finite_times(t_local_s, "t_local_s")
        lo, hi = self.span_local_s
        return np.asarray((t >= lo) & (t <= hi), dtype=np.bool_)

    def extrapolation_limits_s(self, spans: float = EXTRAPOLATION_SPANS) -> tuple[float, float]:
        """Local times a linear model is trusted to reach by extrapolation (s, local clock).

        ``(lo - spans * (hi - lo), hi + spans * (hi - lo))`` for ``span_local_s = (lo,
        hi)``. `apply` does not use it (its ``"extrapolate"`` has no limit); ``kinsync
        clock apply`` refuses times beyond it unless told ``--outside extrapolate``.

        Parameters
        ----------
        spans : float
            Margin on each side, in lengths of the fitted span (>= 0).
        """
        lo, hi = self.span_local_s
        margin_s = spans * (hi - lo)
        return lo - margin_s, hi + margin_s

    def _linear_gps_s(self, t: FloatArray) -> FloatArray:
        scale = 1.0 + self.drift_ppm * 1e-6
        return np.asarray(
            self.reference_gps_s + (t - self.reference_local_s) * scale, dtype=np.float64
        )

    def apply(self, t_local_s: ArrayLike, outside: OutsidePolicy | None = None) -> FloatArray:
        """GPS time of local timestamps.

        Parameters
        ----------
        t_local_s : array_like, shape (...)
            Local clock times (s), finite.
        outside : {"extrapolate", "raise", "nan"}, optional
            Times outside `span_local_s`: ``"extrapolate"`` uses the linear model
            (the piecewise model's linear fit too), ``"raise"`` raises
            `OutsideSpanError`, ``"nan"`` returns NaN there. Default: ``"extrapolate"``
            for the linear model, ``"raise"`` for the piecewise model (never silently).
            `inside_span` says which times were outside. ``"extrapolate"`` has no limit:
            a time on another clock (boot time against Unix time) gets a GPS time decades
            off; `extrapolation_limits_s` gives the limit ``kinsync clock apply`` keeps.

        Returns
        -------
        ndarray, shape (...)
            GPS seconds since the GPS epoch.

        Raises
        ------
        InputError
            A non-finite time or an unknown policy.
        OutsideSpanError
            A time outside the span with ``outside="raise"``.
        """
        policy: OutsidePolicy = outside or ("raise" if self.piecewise else "extrapolate")
        if policy not in OUTSIDE_POLICIES:
            msg = f"outside must be one of {', '.join(OUTSIDE_POLICIES)}, got {outside!r}"
            raise InputError(msg)
        t = _finite_times(t_local_s, "t_local_s")
        out = self._linear_gps_s(t)
        inside = self.inside_span(t)
        if self.knots_local_s is not None and self.knots_gps_s is not None:
            out = np.where(inside, np.interp(t, self.knots_local_s, self.knots_gps_s), out)
        if not np.all(inside):
            if policy == "raise":
                first = float(t.reshape(-1)[~inside.reshape(-1)][0])
                lo, hi = self.span_local_s
                kind = "piecewise " if self.piecewise else ""
                msg = (
                    f"{int(np.count_nonzero(~inside))} local time(s) lie outside the "
                    f"{kind}clock model's span [{lo!r}, {hi!r}] s (first: {first!r}); "
                    "fit the clock over a longer log, or pass outside='extrapolate' (the "
                    "linear model) or outside='nan'"
                )
                raise OutsideSpanError(msg)
            if policy == "nan":
                out = np.where(inside, out, np.nan)
        return np.asarray(out, dtype=np.float64)

    def as_document(self) -> dict[str, Any]:
        """JSON-ready document with every field needed to apply the model (full precision).

        ``offset_s`` is written for reading; `ClockModel.from_document` checks that it
        agrees with the reference times.
        """
        doc: dict[str, Any] = {
            "kind": MODEL_KIND,
            "version": MODEL_VERSION,
            "time_scale": "GPS seconds since 1980-01-06T00:00:00",
            "formula": self.formula,
            "reference_local_s": self.reference_local_s,
            "reference_gps_s": self.reference_gps_s,
            "drift_ppm": self.drift_ppm,
            "offset_s": self.offset_s,
            "span_local_s": list(self.span_local_s),
            "piecewise": self.knots_document(),
        }
        return doc

    def knots_document(self) -> dict[str, list[float]] | None:
        """``piecewise`` of the model file and of ``clock fit --json``: the knots, or None.

        Returns
        -------
        dict or None
            ``{"knots_local_s": [...], "knots_gps_s": [...]}`` (s, K each) for the
            piecewise model; None for the linear one.
        """
        if self.knots_local_s is None or self.knots_gps_s is None:
            return None
        return {
            "knots_local_s": self.knots_local_s.tolist(),
            "knots_gps_s": self.knots_gps_s.tolist(),
        }

    @classmethod
    def from_document(cls, doc: object, source: str = "<document>") -> ClockModel:
        """Build a `ClockModel` from the document `ClockModel.as_document` writes.

        Parameters
        ----------
        doc : object
            The parsed JSON document: an object with ``reference_local_s`` (s, local
            clock), ``reference_gps_s`` (s, GPS time), ``drift_ppm``, ``span_local_s``
            (two local times, s) and ``piecewise`` (null, or ``knots_local_s`` and
            ``knots_gps_s`` lists); ``offset_s`` (s), ``kind`` and ``version``
            optional, checked; other keys (``formula``, ...) ignored.
        source : str
            Where the document came from (a file name), for messages.

        Returns
        -------
        ClockModel

        Raises
        ------
        InputError
            Not an object, another ``kind`` or ``version`` than `MODEL_KIND` and
            `MODEL_VERSION`, missing or non-numeric keys, a GPS time outside
            `GPS_TIME_SPAN_S`, an ``offset_s`` that disagrees with ``reference_gps_s -
            reference_local_s`` by more than 1 us (an edited file), or inconsistent
            piecewise knots.
        """
        if not isinstance(doc, dict):
            msg = f"{source}: expected a JSON object with the clock model's keys"
            raise InputError(msg)
        _check_kind_and_version(doc, source)
        ref_local = _doc_number(doc, "reference_local_s", source)
        ref_gps = _doc_number(doc, "reference_gps_s", source)
        _check_gps_times([ref_gps], "reference_gps_s", source)
        drift = _doc_number(doc, "drift_ppm", source)
        if "offset_s" in doc:
            offset = finite_number(doc["offset_s"], f"{source}: offset_s")
            if abs(offset - (ref_gps - ref_local)) > 1e-6:
                msg = (
                    f"{source}: offset_s {offset!r} disagrees with reference_gps_s - "
                    f"reference_local_s = {ref_gps - ref_local!r}; the model is defined by the "
                    "reference times: edit those (or delete offset_s)"
                )
                raise InputError(msg)
        span = doc.get("span_local_s")
        if span is None:
            msg = f"{source}: missing key 'span_local_s' (local times of the first and last pulse)"
            raise InputError(msg)
        span_arr = _doc_list(span, "span_local_s", source)
        if span_arr.shape != (2,):
            msg = f"{source}: span_local_s must hold two times, got {span!r}"
            raise InputError(msg)
        knots_local = knots_gps = None
        pw = doc.get("piecewise")
        if pw is not None:
            if not isinstance(pw, dict):
                msg = (
                    f"{source}: piecewise must be null or an object with knots_local_s, knots_gps_s"
                )
                raise InputError(msg)
            knots_local = _doc_list(pw.get("knots_local_s"), "piecewise.knots_local_s", source)
            knots_gps = _doc_list(pw.get("knots_gps_s"), "piecewise.knots_gps_s", source)
            _check_gps_times(knots_gps, "piecewise.knots_gps_s", source)
        try:
            model = cls(
                reference_local_s=ref_local,
                reference_gps_s=ref_gps,
                drift_ppm=drift,
                span_local_s=(float(span_arr[0]), float(span_arr[1])),
                knots_local_s=knots_local,
                knots_gps_s=knots_gps,
            )
        except InputError as err:
            msg = f"{source}: {err}"
            raise InputError(msg) from err
        return model


def _check_kind_and_version(doc: dict[str, Any], where: str) -> None:
    """Refuse a document that says it is something else, or a layout this kinsync predates.

    Both keys may be left out (a model written by hand).
    """
    kind = doc.get("kind", MODEL_KIND)
    if kind != MODEL_KIND:
        msg = (
            f"{where}: kind {repr(kind)[:80]} is not a clock model (kind {MODEL_KIND!r}); "
            "is this the right file? kinsync clock fit --model-out writes one"
        )
        raise InputError(msg)
    version = doc.get("version", MODEL_VERSION)
    if isinstance(version, bool) or not isinstance(version, int) or version != MODEL_VERSION:
        msg = (
            f"{where}: version {repr(version)[:80]} is not a clock model version this "
            f"kinsync reads (the number {MODEL_VERSION}); fit the clock again with this "
            "kinsync (clock fit --model-out)"
        )
        raise InputError(msg)


def _check_gps_times(values: Sequence[float] | FloatArray, key: str, where: str) -> None:
    """Refuse a GPS time outside `GPS_TIME_SPAN_S` (1980 to 2100) or after today.

    The one check of `ClockModel` and of the model file reader (which names the file's
    key before building the model). A time after this computer's clock (plus a day,
    `kinsync._unix_time.check_not_future`, as the file readers refuse) is most often
    Unix time given as GPS time, ten years late.

    Parameters
    ----------
    values : sequence of float
        GPS times (s), named ``key`` of document ``where`` in the message.
    """
    lo, hi = GPS_TIME_SPAN_S
    for value in values:
        if not lo <= value <= hi:
            msg = (
                f"{where}: {key} {float(value)!r} s is not a GPS time of a survey: GPS "
                f"time counts seconds since 1980-01-06 (about 1.4e9 s in 2024), from {lo:g} "
                f"to {hi:.4g} s (the year 2100); fix the value, or fit the clock again"
            )
            raise InputError(msg)
    check_not_future(values, lambda _row: f"{where}: {key}")


def _doc_number(doc: dict[str, Any], key: str, where: str) -> float:
    if key not in doc:
        msg = f"{where}: missing key {key!r}; a clock model needs {CLOCK_FORMULA}"
        raise InputError(msg)
    return finite_number(doc[key], f"{where}: {key}")


def _doc_list(value: object, name: str, where: str) -> FloatArray:
    if not isinstance(value, list) or not all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value
    ):
        msg = f"{where}: {name} must be a list of numbers"
        raise InputError(msg)
    return np.asarray(value, dtype=np.float64)
