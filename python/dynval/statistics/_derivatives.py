"""Zero-phase differentiation of sampled joint positions, with the band the filter keeps.

Used by :mod:`dynval.robots` (its public home) and by the physics library of the findings, which
derives q̇ and q̈ from ``q`` when they are not given.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..checks._typing import ArrayLike
from ..checks._validation import check_choice, check_finite, parameter_error, promote_signal, to_float_array

__all__ = ["Derivatives", "differentiate", "checked_differentiate"]


@dataclass(frozen=True)
class Derivatives:
    """Filtered positions and their first two derivatives, with what the filter does.

    ``bandwidth_hz`` is the -3 dB frequency of the position smoothing; ``derivative_bandwidth_hz``
    the -3 dB frequencies ``(velocity, acceleration)`` of the derivative filters relative to the
    ideal differentiators ``(j2πf)^k`` — the band in which ``dq`` and ``ddq`` are trustworthy, each
    computed from the filter's own frequency response. ``delay_s`` is the group delay (0: the
    filters are symmetric, so they do not shift the signal in time).
    """

    q: np.ndarray
    dq: np.ndarray
    ddq: np.ndarray
    method: str
    sample_rate: float
    bandwidth_hz: float
    derivative_bandwidth_hz: tuple[float, float]
    delay_s: float
    settings: dict[str, Any]

    @property
    def input_bandwidth_hz(self) -> float:
        """The band in which ``q``, ``dq`` and ``ddq`` are all trustworthy (the narrowest of the
        three): what ``validate(bandwidth=...)`` takes."""
        return float(min(self.bandwidth_hz, *self.derivative_bandwidth_hz))

    @property
    def description(self) -> str:
        opts = ", ".join(f"{k}={v}" for k, v in self.settings.items())
        vb, ab = self.derivative_bandwidth_hz
        return (f"{self.method} ({opts}) at {self.sample_rate:g} Hz: zero-phase, delay "
                f"{self.delay_s:g} s, -3 dB bandwidth {self.bandwidth_hz:.3g} Hz (positions), "
                f"{vb:.3g} Hz (velocities), {ab:.3g} Hz (accelerations)")


def _minus3db(freq: np.ndarray, gain: np.ndarray) -> float:
    """First frequency where the gain falls below 1/√2 (linear interpolation)."""
    target = 1.0 / math.sqrt(2.0)
    below = np.flatnonzero(gain < target)
    if below.size == 0:
        return float(freq[-1])
    i = int(below[0])
    if i == 0:
        return float(freq[0])
    f0, f1, g0, g1 = freq[i - 1], freq[i], gain[i - 1], gain[i]
    return float(f0 + (g0 - target) * (f1 - f0) / (g0 - g1))


def differentiate(q: ArrayLike, sample_rate: float, *, method: str = "savgol", window: float | None = None,
                  polyorder: int = 4, cutoff: float | None = None, order: int = 4) -> Derivatives:
    """Zero-phase velocities and accelerations from sampled positions.

    Parameters
    ----------
    q : array_like (N,) or (N, n)
        Positions, uniformly sampled.
    sample_rate : float
        Sampling rate in Hz.
    method : {"savgol", "butterworth"}
        Savitzky–Golay: a degree-``polyorder`` polynomial fitted over a centred window of
        ``window`` seconds, differentiated analytically (``scipy.signal.savgol_filter``). The
        default degree 4 keeps the acceleration's band as wide as the velocity's (a cubic's
        second derivative is a much narrower filter).
        Butterworth: an ``order``-th order low-pass with cutoff ``cutoff`` Hz run forward and
        backward (``scipy.signal.filtfilt``, so the squared magnitude applies and the phase
        cancels), then central differences (``numpy.gradient``).
    window : float or None
        Savitzky–Golay window in seconds (default: 0.1 s, at least polyorder + 2 samples; odd).
    cutoff : float or None
        Butterworth cutoff in Hz (default: ``sample_rate / 10``).

    Returns
    -------
    Derivatives
        With ``bandwidth_hz`` computed from the filter's own frequency response and
        ``delay_s = 0``.

    Examples
    --------
    >>> import numpy as np
    >>> from dynval.robots import differentiate
    >>> t = np.arange(1000) / 200.0
    >>> d = differentiate(np.sin(2 * np.pi * t), 200.0)
    >>> round(float(np.max(np.abs(d.dq[50:-50, 0] - 2 * np.pi * np.cos(2 * np.pi * t[50:-50])))), 3)
    0.0
    >>> d.delay_s
    0.0
    """
    check_choice("method", method, ("savgol", "butterworth"))
    if not (isinstance(sample_rate, (int, float)) and math.isfinite(sample_rate) and sample_rate > 0):
        raise parameter_error("sample_rate", "a finite number > 0", sample_rate)
    x = promote_signal(to_float_array(q, "q"), "q")
    check_finite(x, "q")
    return checked_differentiate(x, float(sample_rate), method=method, window=window, polyorder=polyorder,
                                 cutoff=cutoff, order=order)


def _savgol_by_fft(x: np.ndarray, length: int, polyorder: int, deriv: int, delta: float) -> np.ndarray:
    """``scipy.signal.savgol_filter(x, length, polyorder, deriv, delta, axis=0, mode="interp")`` with
    its interior convolution by FFT (the same filter to rounding; half the time of the direct
    convolution on a 20,000-row log): the half windows at the ends are ``savgol_filter``'s own
    polynomial fits of the first and last ``length`` rows, which is all it reads there."""
    import scipy.signal

    n, half = x.shape[0], length // 2
    coeffs = scipy.signal.savgol_coeffs(length, polyorder, deriv=deriv, delta=delta)
    y: np.ndarray = np.asarray(scipy.signal.fftconvolve(x, coeffs[:, None], mode="same", axes=0))
    kw = dict(window_length=length, polyorder=polyorder, deriv=deriv, delta=delta, axis=0, mode="interp")
    y[:half] = scipy.signal.savgol_filter(x[:length], **kw)[:half]
    y[n - half:] = scipy.signal.savgol_filter(x[n - length:], **kw)[length - half:]
    return y


def checked_differentiate(x: np.ndarray, sample_rate: float, *, method: str = "savgol", window: float | None = None,
                          polyorder: int = 4, cutoff: float | None = None, order: int = 4,
                          positions: bool = True, by_fft: bool = False) -> Derivatives:
    """:func:`differentiate` of positions already checked: ``x`` finite float64 (N, m), ``sample_rate``
    finite > 0, ``method`` one of its two (``validate``'s physics library and the stream's filter
    call it on their checked q; the filter's own settings are still checked here).
    ``positions=False`` (Savitzky–Golay only): the smoothed positions are not computed and ``q`` is
    ``x`` as given, for a caller that reads only q̇, q̈ and the bands (one filter pass of three).
    ``by_fft`` (Savitzky–Golay only): q̇ and q̈ by :func:`_savgol_by_fft`, the same filter to rounding."""
    import scipy.signal

    n = x.shape[0]
    dt = 1.0 / sample_rate
    freq = np.linspace(0.0, sample_rate / 2.0, 4097)[1:]
    omega = 2.0 * np.pi * freq
    if method == "savgol":
        if not isinstance(polyorder, int) or polyorder < 2:
            raise parameter_error("polyorder", "an integer >= 2 (accelerations need degree 2)", polyorder)
        w = 0.1 if window is None else window
        length = max(int(round(w * sample_rate)), polyorder + 2)
        length += 1 - length % 2
        if length > n:
            raise parameter_error("window", f"at most N={n} samples long", window)
        kw = dict(window_length=length, polyorder=polyorder, delta=dt, axis=0, mode="interp")
        qs = scipy.signal.savgol_filter(x, deriv=0, **kw) if positions else x
        if by_fft:
            dq, ddq = (_savgol_by_fft(x, length, polyorder, k, dt) for k in (1, 2))
        else:
            dq = scipy.signal.savgol_filter(x, deriv=1, **kw)
            ddq = scipy.signal.savgol_filter(x, deriv=2, **kw)
        gains = []
        for k in range(3):
            coeffs = scipy.signal.savgol_coeffs(length, polyorder, deriv=k, delta=dt)
            _, h = scipy.signal.freqz(coeffs, worN=freq, fs=sample_rate)
            gains.append(np.abs(h) / omega**k)
        bandwidth = _minus3db(freq, gains[0])
        derivative_bw = (_minus3db(freq, gains[1]), _minus3db(freq, gains[2]))
        settings = {"window_samples": length, "window_s": length * dt, "polyorder": polyorder}
    else:
        fc = sample_rate / 10.0 if cutoff is None else cutoff
        if not (isinstance(fc, (int, float)) and 0 < fc < sample_rate / 2):
            raise parameter_error("cutoff", f"a number of Hz with 0 < cutoff < {sample_rate / 2:g}", cutoff)
        if not isinstance(order, int) or order < 1:
            raise parameter_error("order", "a positive integer", order)
        b, a = scipy.signal.butter(order, fc, fs=sample_rate)
        padlen = 3 * max(len(a), len(b))
        if n <= padlen:
            raise parameter_error("q", f"at least {padlen + 1} samples for filtfilt", n)
        qs = scipy.signal.filtfilt(b, a, x, axis=0)
        dq = np.gradient(qs, dt, axis=0)
        ddq = np.gradient(dq, dt, axis=0)
        _, h = scipy.signal.freqz(b, a, worN=freq, fs=sample_rate)
        smooth = np.abs(h) ** 2  # forward and backward: |H|²
        bandwidth = _minus3db(freq, smooth)
        # numpy.gradient's central difference responds with sin(ωT)/T instead of ω.
        central = np.abs(np.sin(omega * dt) / (omega * dt))
        derivative_bw = (_minus3db(freq, smooth * central), _minus3db(freq, smooth * central**2))
        settings = {"order": order, "cutoff_hz": fc}
    return Derivatives(q=qs, dq=dq, ddq=ddq, method="Savitzky–Golay" if method == "savgol" else
                       "Butterworth + filtfilt", sample_rate=float(sample_rate), bandwidth_hz=bandwidth,
                       derivative_bandwidth_hz=derivative_bw, delay_s=0.0, settings=settings)
