"""The run's environment, below every other layer and importing none of fsivsp's but `errors`: MPI ranks
(`parallel`), threads (`threads`), messages (`logs`: logging, the set-up stages), progress bars (`progress`) and
signals (`stopping`)."""
