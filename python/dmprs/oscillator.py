"""A rhythm's frequency, phase and waveform followed online from a measured signal, and a
periodic DMP learned from it while it is demonstrated (docs/method.md §12.5).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from dmprs import _core
from dmprs._arrays import as_count, as_float_array, as_scalar
from dmprs.errors import InvalidInputError
from dmprs.periodic import PeriodicDMP, PeriodicOnlineFit

__all__ = ["AdaptiveOscillator", "RhythmLearner"]


def _sample(value: ArrayLike, n_dof: int) -> NDArray[np.float64]:
    y = np.atleast_1d(as_float_array(value, "y", (0, 1)))
    if y.shape != (n_dof,):
        raise InvalidInputError(f"y has {y.shape[0]} entries, expected {n_dof} (one per coordinate)")
    return y


class AdaptiveOscillator:
    r"""An adaptive frequency oscillator with an adaptive Fourier series in its loop (Petrič,
    Gams, Ijspeert and Žlajpah 2011): fed a periodic signal one sample at a time, it locks onto
    the signal's fundamental frequency and phase and learns its waveform, per coordinate::

        y_hat  = sum_{c=0}^{M} a_c cos(c phi) + b_c sin(c phi)
        phi'   = Omega - K_phi Omega e_n u
        Omega' =       - K_Omega Omega^2 e_n u
        u      = (a_1 sin(phi) - b_1 cos(phi)) / sqrt(a_1^2 + b_1^2)
        a_c' = eta Omega e cos(c phi),   b_c' = eta Omega e sin(c phi)

    ``e = y - y_hat``; ``e_n`` is the driving coordinate's error less its running mean, over its
    running RMS about the baseline ``a_0``; ``u`` is minus the phase derivative of the driving
    coordinate's learned fundamental at unit amplitude (Petrič et al. pull along ``sin(phi)``),
    so the pull does not depend on the phase the signal starts at. The gains scale with
    ``Omega`` so that a rhythm settles in the same number of periods at any frequency and
    amplitude; the harmonics of the signal go into the series' higher terms, so the oscillator
    locks onto the fundamental, not a harmonic.

    With the default gains, a sine with 5 % noise is followed to within 1 % within five periods
    from any starting phase and a guess between 0.7 and 2 times its frequency (docs/method.md
    §12.5). A guess near a strong harmonic can lock onto it: give the rough frequency of the
    rhythm.

    Args:
        frequency: the initial guess (Hz).
        n_dof: coordinates D in each sample (1 to 10,000).
        harmonics: M, terms of each coordinate's Fourier series beyond the mean (1 to 1000).
        drive: the coordinate whose signal moves the oscillator (the one with the clearest
            rhythm); every coordinate's series follows the oscillator's phase.
        frequency_range: ``(low, high)`` in Hz that the frequency is kept within; by default a
            factor of 4 either side of the guess.
        phase_gain, frequency_gain, fourier_gain: ``K_phi``, ``K_Omega`` and ``eta`` per radian
            of the oscillator's phase.
    """

    __slots__ = ("_core",)

    def __init__(
        self,
        frequency: float,
        n_dof: int = 1,
        *,
        harmonics: int = 10,
        drive: int = 0,
        frequency_range: tuple[float, float] | None = None,
        phase_gain: float = 0.5,
        frequency_gain: float = 0.1,
        fourier_gain: float = 0.3,
    ) -> None:
        f = as_scalar(frequency, "frequency", positive=True)
        if frequency_range is None:
            low, high = f / 4.0, f * 4.0
        else:
            try:
                low, high = frequency_range
            except (TypeError, ValueError):
                raise InvalidInputError(f"frequency_range must be a pair (low, high) in Hz; got {frequency_range!r}") from None
            low, high = as_scalar(low, "frequency_range", positive=True), as_scalar(high, "frequency_range", positive=True)
        n = as_count(n_dof, "n_dof", 1)
        self._core = _core.AdaptiveOscillator(
            f, n, as_count(harmonics, "harmonics", 1), as_count(drive, "drive", 0), (low, high),
            (as_scalar(phase_gain, "phase_gain", positive=True),
             as_scalar(frequency_gain, "frequency_gain", positive=True),
             as_scalar(fourier_gain, "fourier_gain", positive=True)),
        )

    def update(self, dt: float, y: ArrayLike) -> None:
        """Takes the sample ``y`` ``(D,)`` measured ``dt`` seconds after the previous one. A
        non-finite sample, or a ``dt`` at which the highest harmonic would alias, is refused,
        naming it, and changes nothing.
        """
        self._core.update(as_scalar(dt, "dt", positive=True), _sample(y, self.n_dof))

    @property
    def n_dof(self) -> int:
        """Coordinates D."""
        return self._core.n_dof

    @property
    def samples(self) -> int:
        """Samples taken so far."""
        return self._core.samples

    @property
    def phase(self) -> float:
        """The oscillator's phase (rad, in [0, 2 pi))."""
        return self._core.phase

    @property
    def frequency(self) -> float:
        """The frequency followed so far (Hz)."""
        return self._core.omega / (2.0 * math.pi)

    @property
    def tau(self) -> float:
        """The periodic DMP's time constant of that frequency, ``1 / Omega`` (s/rad)."""
        return 1.0 / self._core.omega

    @property
    def coefficients(self) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The Fourier coefficients ``(a, b)``, each ``(D, M + 1)``: ``a[:, 0]`` is the baseline,
        ``hypot(a[:, c], b[:, c])`` the amplitude of harmonic c.
        """
        return self._core.coefficients()

    @property
    def baseline(self) -> NDArray[np.float64]:
        """The signal's mean, ``a_0`` per coordinate ``(D,)``."""
        return self.coefficients[0][:, 0].copy()

    def estimate(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The series' position, velocity and acceleration at the current phase, each ``(D,)``:
        the signal as learned, differentiated exactly rather than from noisy samples.
        """
        return self._core.estimate()

    def __copy__(self) -> AdaptiveOscillator:
        twin = object.__new__(AdaptiveOscillator)
        twin._core = self._core.copy()
        return twin

    def __deepcopy__(self, memo: dict[int, Any]) -> AdaptiveOscillator:
        return self.__copy__()

    def __repr__(self) -> str:
        return f"AdaptiveOscillator(n_dof={self.n_dof}, frequency={self.frequency:.6g} Hz, samples={self.samples})"


class RhythmLearner:
    """Learns a :class:`~dmprs.PeriodicDMP` while a rhythm is demonstrated, from positions alone:
    an :class:`AdaptiveOscillator` follows the frequency, phase and waveform, and a
    :class:`~dmprs.PeriodicOnlineFit` learns the weights by recursive least squares from the
    oscillator's phase and the series' exact derivatives (Petrič et al. 2011). :meth:`dmp` gives
    the DMP learned so far, about the signal's baseline at the followed frequency.

    ``frequency`` is the guess (Hz); ``forgetting`` the fit's lambda per sample (0.999 at 1 kHz
    remembers about one second); the other keywords are :class:`AdaptiveOscillator`'s.
    """

    __slots__ = ("fit", "oscillator")

    def __init__(self, frequency: float, n_dof: int = 1, n_basis: int = 25, *,
                 forgetting: float = 0.999, **oscillator: Any) -> None:
        self.oscillator = AdaptiveOscillator(frequency, n_dof, **oscillator)
        self.fit = PeriodicOnlineFit(self.oscillator.n_dof, n_basis, forgetting=forgetting)

    def update(self, dt: float, y: ArrayLike) -> None:
        """Takes the sample ``y`` ``(D,)`` measured ``dt`` seconds after the previous one."""
        osc = self.oscillator
        osc.update(dt, y)
        pos, vel, acc = osc.estimate()
        self.fit.update(osc.phase, osc.tau, pos, vel, acc, osc.baseline, np.ones(osc.n_dof))

    def dmp(self) -> PeriodicDMP:
        """The periodic DMP learned so far: the fit's weights about the signal's baseline, at the
        followed frequency, started from the series' present position.
        """
        osc = self.oscillator
        return self.fit.dmp(osc.baseline, osc.estimate()[0], osc.tau)
