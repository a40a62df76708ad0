"""The command-line programs (``visuomotor-<name>`` console scripts, ``scripts/<name>.py``
wrappers): argument parsing and wiring of the harness and studies."""
