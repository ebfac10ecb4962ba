"""Package data: ``mechanism.schema.json``, the JSON Schema of the mechanism file, and
its builder (:mod:`mechsolve.analyses.schema.build`, from the model's key declarations;
``mechsolve schema`` prints the file)."""
