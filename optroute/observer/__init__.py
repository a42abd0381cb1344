"""The onboard parametric-roll observer of thyssenkrupp EP 2377756 and the motions it observes.

* :mod:`.motions` — heave, roll and pitch at 50 Hz from a damped Mathieu roll model with the
  GM variation of a wave along the hull (:func:`~.motions.simulate_motions`);
* :mod:`.criteria` — the criteria K1–K5 and the resonance level RL, one sample at a time;
* :mod:`.level` — settings, the righting-moment characteristic, the batch function
  :func:`~.level.observe` and the streaming :class:`~.level.ResonanceObserver`;
* :mod:`.io` — motion logs (CSV, NetCDF) and righting-moment tables.

The package sits beside :mod:`optroute.weather` in the layers: it uses the physics only.
Nothing is imported here, so loading one module does not load the others.
"""
