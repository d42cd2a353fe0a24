"""Prompt templates and the JSON Schemas of structured LLM outputs, shipped as package data."""
