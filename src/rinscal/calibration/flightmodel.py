"""What PX4 and ArduPilot can hold of a thermal model: a clamped cubic in T per channel.

:func:`flight_model` turns a model file into one whose every gyro and accelerometer channel
is a ``poly-t`` (degree ≤ 3), ``px4`` or ``ardupilot`` model, for
:mod:`rinscal.calibration.export`: where ``fit --method auto`` chose a model the firmware
cannot hold, the channel's best candidate it can hold by held-out RMS, fitted on all the
data (``selection.flight`` of the model file), with what that costs (:class:`FlightChoice`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

from rinscal.calibration.modelfile import FittedModel
from rinscal.errors import ConfigError

__all__ = ["FLIGHT_METHODS", "FlightChoice", "flight_model"]

#: Channel methods that PX4 and ArduPilot can represent (a clamped cubic in T).
FLIGHT_METHODS: tuple[str, ...] = ("poly-t", "px4", "ardupilot")
_AXES = ("x", "y", "z")


@dataclass(frozen=True)
class FlightChoice:
    """A channel exported to PX4/ArduPilot with another candidate than the model's choice.

    Attributes
    ----------
    channel : str
        The channel.
    unit : str or None
        Its unit (the log's), of the RMS figures.
    chosen, exported : str
        The candidate ``fit --method auto`` chose (which the firmware cannot hold) and the
        one written (e.g. ``regression 1,2,0`` and ``poly-t 3``).
    chosen_rms, exported_rms : float [unit]
        Their held-out RMS (of 60 s means of the residual, as ``auto`` scores).
    """

    channel: str
    unit: str | None
    chosen: str
    chosen_rms: float
    exported: str
    exported_rms: float

    @property
    def cost(self) -> float:
        """Held-out RMS given up [unit]: exported − chosen (≥ 0 unless within noise)."""
        return self.exported_rms - self.chosen_rms

    @property
    def ratio(self) -> float:
        """Exported held-out RMS over the chosen's (inf when the chosen's is 0)."""
        return self.exported_rms / self.chosen_rms if self.chosen_rms > 0 else float("inf")

    def describe(self) -> str:
        """One line: the change and its cost."""
        u = self.unit or "log units"
        return (
            f"{self.channel}: {self.exported} (held-out RMS {self.exported_rms:.4g} {u}) in "
            f"place of the model's {self.chosen} ({self.chosen_rms:.4g} {u}), "
            f"{self.cost:+.3g} {u}, x{self.ratio:.3g}"
        )


def _holdable(params: Mapping) -> bool:
    """Whether PX4 and ArduPilot can hold a channel model: a clamped cubic in T."""
    method = params.get("method")
    return method in FLIGHT_METHODS and (method != "poly-t" or len(params["coef"]) <= 4)


def _what(params: Mapping) -> str:
    """A channel model's method in words (``a regression model``, ``a degree-4 poly-t``)."""
    if params.get("method") == "poly-t":
        return f"a degree-{len(params['coef']) - 1} poly-t model"
    return f"a {params.get('method')} model"


def flight_model(model: FittedModel) -> tuple[FittedModel, tuple[FlightChoice, ...]]:
    """The model as PX4 and ArduPilot can hold it: a clamped cubic in T per sensor channel.

    A gyro or accelerometer channel whose model is not a ``poly-t`` (degree ≤ 3), ``px4`` or
    ``ardupilot`` model is replaced by the candidate of ``fit --method auto`` of least
    held-out RMS among those the firmware can hold (``none``, ``poly-t`` 1-3, ``px4``,
    ``ardupilot``; fewer parameters on a tie), fitted on all the data, from the channel's
    ``selection.flight``. Other channels are kept as they are.

    Parameters
    ----------
    model : FittedModel
        The model file (unchanged).

    Returns
    -------
    model : FittedModel
        A copy with the replaced channels (to export only: ``compensate`` and ``navigate``
        apply the file's own choice).
    changed : tuple of FlightChoice
        The replaced channels, in channel order, with the held-out RMS of both candidates.

    Raises
    ------
    ConfigError
        Naming every channel that has no such candidate (a model fitted with another
        method, or an ``auto`` file written before model files kept them) and what to do.
    """
    models = dict(model.models)
    changed: list[FlightChoice] = []
    refused: list[tuple[str, str, str]] = []
    for c in (f"{s}_{a}" for s in ("gyro", "accel") for a in _AXES):
        cm = models.get(c)
        if cm is None or _holdable(cm.params):
            continue
        sel = cm.selection
        flight = sel.get("flight") if sel is not None else None
        rows = {r.get("name"): r for r in sel["table"]} if sel is not None else {}
        scored = [
            (float(rows[n]["heldout_rms"]), int(rows[n].get("n_params", 0)), n)
            for n in (flight or {})
            if n in rows and rows[n].get("heldout_rms") is not None
        ]
        if not scored:
            why = (
                "it was not fitted with --method auto"
                if sel is None
                else "the file was written before model files kept them, schema version < 4"
                if flight is None
                else "none was among the candidates fitted (fit --candidates) or fitted well"
            )
            refused.append((c, _what(cm.params), why))
            continue
        rms, _, name = min(scored)
        chosen = str(sel["chosen"]) if sel is not None else cm.params["method"]
        chosen_rms = rows.get(chosen, {}).get("heldout_rms")
        # a model of T alone: its T range (the clamp of a poly-t), no joint domain
        models[c] = dataclasses.replace(
            cm,
            params=flight[name],  # type: ignore[index]
            train_range=cm.train_range[:1],
            domain=None,
        )
        ref = float("nan") if chosen_rms is None else float(chosen_rms)
        changed.append(FlightChoice(c, cm.unit, chosen, ref, name, rms))
    if refused:
        what = "; ".join(f"{c} is {m}" for c, m, _ in refused)
        whys = sorted({w for _, _, w in refused})
        raise ConfigError(
            f"{what}. PX4 and ArduPilot take a clamped cubic in temperature (a poly-t of "
            "degree <= 3, px4 or ardupilot model per channel), and the model file keeps none "
            f"for {'this channel' if len(refused) == 1 else 'these channels'} "
            f"({'; '.join(whys)}): refit with 'rinscal fit LOG --method auto' (it keeps each "
            "channel's best cubic for this export) or '--method poly-t' (or px4, ardupilot), "
            "or export this model as a C header (--format c) instead"
        )
    if not changed:
        return model, ()
    return dataclasses.replace(model, models=models), tuple(changed)
