"""The trace layer: what a run leaves behind. The recorder that writes the JSONL trace and the summary, reading a
trace back (replay), and the compiled checks that validate its lines."""
