"""What every stage shares: errors and failure kinds, paths, progress lines, provenance,
statistics, drawings and worker processes."""
