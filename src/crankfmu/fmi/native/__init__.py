"""The native FMUs: the C runtime's model file (``model_file``), a mechanism's and a component's
variables and model description (``model``, ``components``, ``fmi3``) and their packaging
(``build``); the C sources themselves are crankfmu.native's."""
