"""The node-graph emitter: a staged shader lowered to a plan of Blender nodes (``lower``, building
the plan types of ``plan``), cut into nested groups (``partition``), checked against Cycles' SVM
register budget (``svm``). Pure data without bpy: ``lamella.blender.node_group`` builds the plan."""
