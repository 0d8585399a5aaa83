# blender -b scene.blend --python batch_apply.py -- STACK.json MATERIAL OUT.blend
import sys
import bpy

lamella = next(m for n, m in sys.modules.items() if n.startswith("bl_ext.") and n.endswith(".lamella"))
stack_file, material_name, out_file = sys.argv[sys.argv.index("--") + 1:]
material = bpy.data.materials.get(material_name) or bpy.data.materials.new(material_name)
with open(stack_file) as f:
    lamella.apply_stack(material, f.read())  # a bad stack raises StackError naming layer and field
print(material.name, "now shows", lamella.read_stack(material)["name"] or stack_file)
bpy.ops.wm.save_as_mainfile(filepath=out_file)
