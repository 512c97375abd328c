"""Case files (TOML) into validated cases: the one `Case` type and the sections every case file has (`case`,
with the low-level readers of `readers`), a production run's case (`production`: data, boundaries, output,
checkpoints) and ``--set`` overrides (`overrides`). Every bad value is an `errors.CaseError` naming its field."""
