"""The certificate's history: earlier calibrations of the same robot, with the parameters that changed significantly."""

from __future__ import annotations

from armcal.results.changes import changes, basis
from armcal.results.schema import HistoryEntry, ParameterChange, Results


def history_entries(current: Results, earlier: list[tuple[str, Results]]) -> list[HistoryEntry]:
    """One entry per earlier results (its source, as read), oldest first; changes against ``current``."""
    entries = []
    for source, old in sorted(earlier, key=lambda pair: pair[1].created):
        found = changes(old.parameters, current.parameters, basis(old), basis(current))
        validation = old.residuals.validation
        entries.append(HistoryEntry(
            source=source,
            created=old.created,
            run_id=old.run_id,
            certificate_number=old.report.certificate_number,
            status=old.status,
            unit=old.device.unit,
            rms_calibration=old.residuals.calibration.after.rms,
            rms_validation=validation.after.rms if validation else None,
            compared=sum(c.z is not None for c in found),
            significant=[ParameterChange(name=c.name, unit=c.unit, old=c.old, new=c.new, change=c.new - c.old, z=c.z) for c in found if c.significant],
        ))
    return entries
