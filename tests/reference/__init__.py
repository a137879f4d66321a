"""Independent reference models (numpy only) that the tracer's results are checked against."""
