"""Placeholder: this plugin registers nothing yet."""
