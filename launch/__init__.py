"""The launcher (``python -m launch FILE.yaml``): YAML launch files parsed safely with file:line errors
(``yaml_source``, ``description``), substitutions (``substitutions``), resolution into a plan
(``resolve``), and supervision of the node processes (``supervisor``, ``readiness``, ``reaper``)."""
