"""The model (1)–(3) as data: material constants (`materials`), user expressions (`expressions`, a whitelist
parser), fields of x, y, z, t (`fields`), the data a scheme runs on (`data`) and manufactured solutions
(`manufactured`). Imports `runtime` and `errors` only."""
