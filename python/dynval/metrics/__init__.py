"""The public metric functions (contract §3), their results and the convention profiles."""
