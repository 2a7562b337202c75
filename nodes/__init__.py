"""Zenroid nodes: the processes of the stack (simulator, controllers, state publisher, tools)."""
