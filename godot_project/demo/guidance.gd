extends RefCounted
## The missile-guidance demo's math, apart from any node so tests can check it
## (tests/godot/tests/test_demo_guidance.gd): the lead intercept point the launcher aims at, and
## augmented proportional navigation for the missiles. All vectors in one frame (the world's).


## The smallest t > 0 with |d + v·t| = s·t: when a missile leaving now from the origin in a
## straight line at speed `s` meets a target at offset `d` that keeps its velocity `v`.
## Returns -1.0 when there is no such t (the target outruns the missile); 0.0 when d is zero.
static func intercept_time(d: Vector3, v: Vector3, s: float) -> float:
	# |d + v t|² = s² t²  ⇔  (v·v − s²) t² + 2 (d·v) t + d·d = 0
	var c := d.dot(d)
	if c <= 0.0:
		return 0.0
	if s <= 0.0:
		return -1.0
	var a := v.dot(v) - s * s
	var b := 2.0 * d.dot(v)
	if absf(a) <= 1e-9 * s * s:
		# Target as fast as the missile: the equation is linear, 2 (d·v) t + d·d = 0.
		return -c / b if b < 0.0 else -1.0
	var disc := b * b - 4.0 * a * c
	if disc < 0.0:
		return -1.0
	# The two roots without cancellation (Numerical Recipes §5.6): q = −(b + sign(b)·√disc)/2.
	var q := -0.5 * (b + (signf(b) if b != 0.0 else 1.0) * sqrt(disc))
	var t1 := q / a
	var t2 := c / q if q != 0.0 else -1.0
	var best := -1.0
	for t in [t1, t2]:
		if t > 0.0 and (best < 0.0 or t < best):
			best = t
	return best


## Where to aim from `shooter` to meet a target at `target` moving at `target_velocity` with a
## missile of speed `s`: the lead intercept point, or the target itself when there is no intercept.
static func lead_point(shooter: Vector3, target: Vector3, target_velocity: Vector3, s: float) -> Vector3:
	var t := intercept_time(target - shooter, target_velocity, s)
	return target + target_velocity * t if t > 0.0 else target


## The commanded acceleration of augmented proportional navigation (Zarchan, "Tactical and
## Strategic Missile Guidance", ch. 8), in 3-D vector form:
##   a = N · Vc · (Ω × r̂) + N/2 · a_T⊥,   Ω = (r × v_rel) / |r|²,   Vc = −(r · v_rel) / |r|
## r = target − missile, v_rel = its rate, Ω the line-of-sight rate (rad/s), Vc the closing speed,
## a_T⊥ the target's acceleration across the line of sight. The missile flies at constant speed, so
## only the part across its own velocity is kept, and its size is capped at `max_accel` (the
## turn rate cap times the speed). N = 3..5; target_accel = 0 gives plain proportional navigation.
static func pn_acceleration(r: Vector3, v_rel: Vector3, missile_velocity: Vector3, target_accel: Vector3,
		n: float, max_accel: float) -> Vector3:
	var r2 := r.length_squared()
	if r2 <= 1e-12:
		return Vector3.ZERO
	var r_len := sqrt(r2)
	var los := r / r_len
	var los_rate := r.cross(v_rel) / r2
	var closing_speed := -r.dot(v_rel) / r_len
	var a := n * closing_speed * los_rate.cross(los)
	a += 0.5 * n * (target_accel - los * target_accel.dot(los))
	var speed2 := missile_velocity.length_squared()
	if speed2 > 1e-12:
		a -= missile_velocity * (a.dot(missile_velocity) / speed2)  # lateral only
	var size := a.length()
	if size > max_accel:
		a *= max_accel / size
	return a


## One constant-speed step of a missile: turns its velocity by `accel` for `dt` seconds (the
## speed kept), moves it. Returns [position, velocity].
static func step_missile(position: Vector3, velocity: Vector3, accel: Vector3, dt: float) -> Array:
	var speed := velocity.length()
	var v := (velocity + accel * dt).normalized() * speed
	return [position + v * dt, v]


## The smallest distance between two points moving linearly during one step, from their offset
## (other − this) at the start of the step to the one at its end: a fast missile must not step
## over its target between two frames.
static func closest_approach(offset_start: Vector3, offset_end: Vector3) -> float:
	var delta := offset_end - offset_start
	var len2 := delta.length_squared()
	var u := 0.0 if len2 <= 1e-12 else clampf(-offset_start.dot(delta) / len2, 0.0, 1.0)
	return (offset_start + delta * u).length()
