"""File-system rules that every command follows, one module per idea.

- :mod:`.inside`: paths named inside project files never leave the project folder
  (:func:`.inside.resolve_inside`), compared as real paths (symlinks resolved), never as string prefixes.
- :mod:`.guard`: nothing is written inside an input project, onto an input file, or through a
  symlink (:class:`.guard.OutputGuard`; every command checks each path it writes).
- :mod:`.atomic`: output is written atomically (:func:`.atomic.atomic_write_bytes`): a crash leaves
  either the old file or the new one, never half of one; the temporary file has a unique name in
  the target folder (two runs into one folder do not collide) and is removed on any error or interruption.
- :mod:`.strict_json`: no NaN or Infinity is ever written as JSON (:func:`.atomic.atomic_write_json`).
- :mod:`.names`: file and folder names (the one file a name is on every disk, names kept apart,
  paths named from a project's own name); :mod:`.walk`: the one folder walk; :mod:`.inputs`: the
  inputs a command is given; :mod:`.disk`: what the disk says of a file (digest, stamp, space).
"""
