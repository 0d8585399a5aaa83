"""The traced IR and its passes: the tracer (``trace``, with the table of traced operations
``traced_ops``), the closures a traced model ends in (``closures``), staging into view tables and a
traced part (``staging``, with ``live_axes`` for tables over linked parameters), the closure budget
(``lobe_budget``) and the shader's sockets (``sockets``). Both emitters (``backends.osl``,
``backends.nodes``) start from here."""
