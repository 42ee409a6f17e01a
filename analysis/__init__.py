"""Records -> tables and plots. No solver logic here: everything comes from results/*/*.jsonl and results/paper/."""
