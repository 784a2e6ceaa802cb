extends RefCounted
## The character demo's ground: a floor, a ramp up, a landing and two steps down, each a
## StaticBody3D with a collision shape (the feet's ray casts hit these) and a mesh. The walk runs
## along +X on the lane z ∈ [-LANE, LANE].

const LANE := 0.9
const RAMP_START := 0.0
const RAMP_END := 2.0
const TOP := 0.3
const LANDING_END := 3.2
## Steps down from the landing: [x where the step ends, its top].
const STEPS := [[3.55, 0.2], [3.9, 0.1]]


## Builds the ground under `parent`.
static func build(parent: Node3D) -> void:
	var stone := StandardMaterial3D.new()
	stone.albedo_color = Color(0.5, 0.46, 0.42)
	stone.roughness = 0.9
	var floor_material := StandardMaterial3D.new()
	floor_material.albedo_texture = _checker(Color(0.36, 0.4, 0.36), Color(0.31, 0.35, 0.31))
	floor_material.texture_filter = BaseMaterial3D.TEXTURE_FILTER_LINEAR_WITH_MIPMAPS
	floor_material.uv1_triplanar = true
	floor_material.uv1_scale = Vector3.ONE * 0.5
	floor_material.roughness = 0.95
	_box(parent, "Floor", Vector3(-12, -0.2, -8), Vector3(16, 0.0, 8), floor_material)
	_ramp(parent, stone)
	_box(parent, "Landing", Vector3(RAMP_END, 0.0, -LANE), Vector3(LANDING_END, TOP, LANE), stone)
	var x := LANDING_END
	for i in STEPS.size():
		var step: Array = STEPS[i]
		_box(parent, "Step%d" % (i + 1), Vector3(x, 0.0, -LANE), Vector3(step[0], step[1], LANE), stone)
		x = step[0]


## The height of the course's surface at `x` on the lane (m): what the ray casts should find.
static func height_at(x: float) -> float:
	if x < RAMP_START:
		return 0.0
	if x < RAMP_END:
		return TOP * (x - RAMP_START) / (RAMP_END - RAMP_START)
	if x < LANDING_END:
		return TOP
	for step in STEPS:
		if x < step[0]:
			return step[1]
	return 0.0


## An axis-aligned box from corner `lo` to corner `hi`.
static func _box(parent: Node3D, name: String, lo: Vector3, hi: Vector3, material: Material) -> void:
	var size := hi - lo
	var mesh := BoxMesh.new()
	mesh.size = size
	var shape := BoxShape3D.new()
	shape.size = size
	_body(parent, name, mesh, shape, material, (lo + hi) * 0.5)


## A wedge: floor level at RAMP_START, TOP at RAMP_END, across the lane.
static func _ramp(parent: Node3D, material: Material) -> void:
	var a := Vector3(RAMP_START, 0, -LANE)
	var b := Vector3(RAMP_END, 0, -LANE)
	var c := Vector3(RAMP_END, TOP, -LANE)
	var d := Vector3(RAMP_START, 0, LANE)
	var e := Vector3(RAMP_END, 0, LANE)
	var f := Vector3(RAMP_END, TOP, LANE)
	var st := SurfaceTool.new()
	st.begin(Mesh.PRIMITIVE_TRIANGLES)
	var centre := (a + b + c + d + e + f) / 6.0
	for tri in [[a, c, b], [d, e, f], [a, d, f], [a, f, c], [b, c, f], [b, f, e]]:
		var n: Vector3 = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalized()
		if n.dot(tri[0] - centre) > 0.0:
			# Counter-clockwise seen from outside: Godot's front faces are clockwise.
			tri = [tri[0], tri[2], tri[1]]
		else:
			n = -n
		for v in tri:
			st.set_normal(n)
			st.add_vertex(v)
	var shape := ConvexPolygonShape3D.new()
	shape.points = PackedVector3Array([a, b, c, d, e, f])
	_body(parent, "Ramp", st.commit(), shape, material, Vector3.ZERO)


static func _body(parent: Node3D, name: String, mesh: Mesh, shape: Shape3D, material: Material, at: Vector3) -> void:
	var body := StaticBody3D.new()
	body.name = name
	body.position = at
	var collision := CollisionShape3D.new()
	collision.shape = shape
	body.add_child(collision)
	var view := MeshInstance3D.new()
	view.mesh = mesh
	view.material_override = material
	body.add_child(view)
	parent.add_child(body)


## A two-tone checker (1 m squares at uv1_scale 0.5) so the ground's motion reads on screen.
static func _checker(a: Color, b: Color) -> ImageTexture:
	var image := Image.create(64, 64, true, Image.FORMAT_RGB8)
	for y in 64:
		for x in 64:
			image.set_pixel(x, y, a if ((x >> 5) + (y >> 5)) % 2 == 0 else b)
	image.generate_mipmaps()
	return ImageTexture.create_from_image(image)
