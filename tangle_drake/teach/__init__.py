"""``tangle-drake teach``: from a user's mesh to a trained, benchmarked model in one command."""
