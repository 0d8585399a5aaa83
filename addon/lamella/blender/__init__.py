"""Everything that needs bpy lives here (DESIGN.md): scene building and rendering for now."""
