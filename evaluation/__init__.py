"""Evaluation: Hajj search-and-rescue scenarios, campaigns, metrics and the paper's statistics pipeline."""
