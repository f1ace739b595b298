"""Instruments that measure the model from outside (``saltstudy bench ...``, ``saltstudy probe
...``): an edit here changes no archive and recompiles no kernel."""
