"""The discretisation of Section 5.2 on a mesh: the spaces V_h, Q_h, S_h (`spaces`), the weak forms of (5.1)
(`forms`) and the data's load vectors (`loads`). Imports `geometry`, `model`, `runtime`, `errors`."""
