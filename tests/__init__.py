"""optplan's tests, one package per part of optplan (tests/<family>/)."""
