extends RefCounted
## What the two demo scenes share: their command-line options, the solver list of their UI, the
## per-second statistics they print when run headless, and screenshots.
##
## User arguments (after `--` on Godot's command line):
##   --demo-seconds=N     run N seconds of simulated time, print a line a second and a final
##                        `demo: PASS ...` / `demo: FAIL <reason>` line, quit (0 on PASS)
##   --solver=NAME        auto, dls, bfgs, jacobian, ccd, fabrik
##   --screenshot=PATH    save one rendered frame as PNG (needs a real renderer, not --headless),
##   --screenshot-at=S    taken after S seconds of simulated time (default 3), then quit
##   --seed=N             the missile demo's random flight paths
##   --start-at=S         the character demo: start S seconds into its lap

## The solvers the demos offer: label, IKChain.Solver value, command-line name. Two Bone is not
## offered: it solves exactly two joints and neither demo has two.
const SOLVERS := [
	["Auto (picks DLS here)", 6, "auto"],
	["Damped least squares", 3, "dls"],
	["BFGS", 4, "bfgs"],
	["Jacobian pseudo-inverse", 2, "jacobian"],
	["CCD", 1, "ccd"],
	["FABRIK", 5, "fabrik"],
]


## The user arguments as a Dictionary: demo_seconds (0 = run until closed), solver (-1 = the
## scene's own), screenshot ("" = none), screenshot_at, seed, start_at. Unknown arguments are
## reported.
static func options() -> Dictionary:
	var o := {"demo_seconds": 0.0, "solver": -1, "screenshot": "", "screenshot_at": 3.0, "seed": -1, "start_at": 0.0}
	for arg in OS.get_cmdline_user_args():
		var value: String = arg.get_slice("=", 1)
		if arg.begins_with("--demo-seconds="):
			o["demo_seconds"] = maxf(value.to_float(), 0.0)
		elif arg.begins_with("--solver="):
			o["solver"] = solver_by_name(value)
			if o["solver"] < 0:
				push_error("demo: unknown solver in %s; use one of %s" % [arg, ", ".join(SOLVERS.map(func(s): return s[2]))])
		elif arg.begins_with("--screenshot="):
			o["screenshot"] = value
		elif arg.begins_with("--screenshot-at="):
			o["screenshot_at"] = maxf(value.to_float(), 0.0)
		elif arg.begins_with("--start-at="):
			o["start_at"] = maxf(value.to_float(), 0.0)
		elif arg.begins_with("--seed="):
			o["seed"] = value.to_int()
		else:
			push_error("demo: unknown argument %s (see res://demo/demo_cli.gd)" % arg)
	return o


static func solver_by_name(name: String) -> int:
	for s in SOLVERS:
		if s[2] == name.to_lower():
			return s[1]
	return -1


static func solver_label(solver: int) -> String:
	for s in SOLVERS:
		if s[1] == solver:
			return s[0]
	return "solver %d" % solver


## Fills an OptionButton with SOLVERS (item id = the IKChain.Solver value), selects `current`.
static func fill_solver_menu(menu: OptionButton, current: int) -> void:
	menu.clear()
	for s in SOLVERS:
		menu.add_item(s[0], s[1])
	menu.select(maxi(menu.get_item_index(current), 0))


## Saves the viewport's next drawn frame as a PNG `width` pixels wide. Returns the error code.
static func save_screenshot(viewport: Viewport, path: String, width := 960) -> int:
	await RenderingServer.frame_post_draw
	var image := viewport.get_texture().get_image()
	if image == null or image.is_empty():
		push_error("demo: nothing rendered to save in %s (a screenshot needs a renderer, not --headless)" % path)
		return ERR_UNAVAILABLE
	if image.get_width() > width:
		image.resize(width, int(round(image.get_height() * float(width) / image.get_width())), Image.INTERPOLATE_LANCZOS)
	DirAccess.make_dir_recursive_absolute(path.get_base_dir())
	var err := image.save_png(path)
	if err != OK:
		push_error("demo: could not write %s (error %d)" % [path, err])
	else:
		print("demo: screenshot %s (%dx%d)" % [path, image.get_width(), image.get_height()])
	return err


## Averages of per-frame samples, kept per key (e.g. "error", "micros").
class Stats:
	var sums := {}
	var counts := {}

	func add(key: String, value: float) -> void:
		sums[key] = sums.get(key, 0.0) + value
		counts[key] = counts.get(key, 0) + 1

	func mean(key: String) -> float:
		return sums.get(key, 0.0) / counts[key] if counts.get(key, 0) > 0 else NAN

	func count(key: String) -> int:
		return counts.get(key, 0)

	func clear() -> void:
		sums.clear()
		counts.clear()
