"""The tangle-data simulator (paper, section III-B): label picks as tangled or not, at scale."""
