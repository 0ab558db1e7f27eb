"""Terminal UI (Textual) for the variable browser: entity, publish/subscribe and administration tables."""
