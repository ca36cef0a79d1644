"""Input and output: config loading, result files, VTK export."""
