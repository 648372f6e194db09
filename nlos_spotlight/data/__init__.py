"""Synthetic datasets: configuration, generation in shards, on-disk format and reading."""
