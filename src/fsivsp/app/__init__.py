"""The commands and the API's entry: the command line (`cli`, `arguments`), ``fsivsp.run`` (`api`), a
production run's loop (`loop`) and the estimate before set-up (`estimate`). The top layer: imports any other."""
