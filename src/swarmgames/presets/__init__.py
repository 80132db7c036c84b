"""Built-in scenario files (TOML). ``swarmgames config show NAME`` prints one resolved."""
