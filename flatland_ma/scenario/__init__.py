"""The scenario file format and nothing else: specs (pydantic, frozen, strict), their
checks, the loader with errors located by file, line and key path, overrides, the JSON
schema and the reference scores. It imports nothing above it."""
