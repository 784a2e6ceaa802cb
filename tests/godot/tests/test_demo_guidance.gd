extends "res://lib/ik_test.gd"
## The missile-guidance demo's math (godot_project/demo/guidance.gd): the lead intercept time
## against closed forms and its defining equation |d + v·t| = s·t, proportional navigation's
## command, and a closed-loop chase where navigation makes the difference between hit and miss.

const Guidance := preload("res://demo/guidance.gd")


func test_intercept_closed_forms() -> void:
	# Crossing at right angles: 100² + (30 t)² = (50 t)² → t = 2.5.
	check_near(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(0, 30, 0), 50.0), 2.5, 1e-9, "crossing")
	# Head-on: the gap closes at 10 + 40 m/s.
	check_near(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(-10, 0, 0), 40.0), 2.0, 1e-9, "head-on")
	# Receding slower than the missile: 100 m at 50 − 20 m/s.
	check_near(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(20, 0, 0), 50.0), 100.0 / 30.0, 1e-9, "receding")
	# A target as fast as the missile (the linear case), coming closer: |100 − 50 t| = 50 t → t = 1.
	check_near(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(-50, 0, 0), 50.0), 1.0, 1e-9, "same speed, closing")
	# Faster than the missile and closing: two positive roots, 100/110 and 100/10; the first counts.
	check_near(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(-60, 0, 0), 50.0), 100.0 / 110.0, 1e-9,
			"faster, closing: the smaller root")


func test_intercept_none() -> void:
	check_eq(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(60, 0, 0), 50.0), -1.0, "outrunning target")
	check_eq(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(50, 0, 0), 50.0), -1.0, "same speed, receding")
	check_eq(Guidance.intercept_time(Vector3(100, 0, 0), Vector3(0, 80, 0), 50.0), -1.0, "fast crossing (no real root)")
	check_eq(Guidance.intercept_time(Vector3(100, 0, 0), Vector3.ZERO, 0.0), -1.0, "missile speed 0")
	check_eq(Guidance.intercept_time(Vector3.ZERO, Vector3(10, 0, 0), 50.0), 0.0, "target at the muzzle")
	# No intercept: the launcher aims at the target itself.
	var target := Vector3(30, 20, -40)
	check_eq(Guidance.lead_point(Vector3.ZERO, target, Vector3(0, 0, -90), 50.0), target, "lead point without intercept")


## 2,000 random cases: whenever there is a t, it solves |d + v t| = s t and no smaller positive t
## does (the quadratic's other root is not in (0, t)); whenever there is none, |d + v t| − s t
## stays positive on a 0.1 s grid up to 60 s.
func test_intercept_satisfies_its_equation() -> void:
	var rng := RandomNumberGenerator.new()
	rng.seed = 8
	var solved := 0
	var worst := 0.0
	for i in 2000:
		var d := Vector3(rng.randf_range(-200, 200), rng.randf_range(-200, 200), rng.randf_range(-200, 200))
		var v := Vector3(rng.randf_range(-80, 80), rng.randf_range(-80, 80), rng.randf_range(-80, 80))
		var s := rng.randf_range(10.0, 120.0)
		var t := Guidance.intercept_time(d, v, s)
		if t > 0.0:
			solved += 1
			worst = maxf(worst, absf((d + v * t).length() - s * t) / (s * t))
			# The roots' product is c/a: the other root is (d·d) / ((v·v − s²) t).
			var a := v.dot(v) - s * s
			if absf(a) > 1e-6:
				var other := d.dot(d) / (a * t)
				if not check(other <= 0.0 or other >= t * (1.0 - 1e-9), "case %d: a smaller positive root %f < %f" % [i, other, t]):
					return
		else:
			if not check(t == -1.0, "case %d: no intercept must be -1, got %f" % [i, t]):
				return
			# |d + v t| − s t starts at |d| > 0; with no root it never changes sign.
			var lowest := INF
			for k in range(1, 601):
				var tk := k * 0.1
				lowest = minf(lowest, (d + v * tk).length() - s * tk)
			if not check(lowest > 0.0, "case %d: reported none, but |d + v t| − s t reaches %f by 60 s" % [i, lowest]):
				return
	# Vector3 is single precision (its dot products round at ~1e-7): measured worst 3.5e-6.
	check_le(worst, 2e-5, "largest relative | |d + v t| − s t | / (s t)")
	check(solved > 500 and solved < 2000, "both kinds of case were drawn (%d of 2000 solvable)" % solved)


func test_pn_command() -> void:
	var v_missile := Vector3(0, 0, -50)
	# On a collision course (line of sight not turning) plain PN commands nothing.
	var a0 := Guidance.pn_acceleration(Vector3(0, 0, -100), Vector3(0, 0, 50), v_missile, Vector3.ZERO, 4.0, 1000.0)
	check_le(a0.length(), 1e-9, "|a| on a collision course")
	# A target crossing to +x: the line of sight turns toward +x, so does the command, and
	# |a| = N · Vc · |λ̇| = 4 · 50 · (10 / 100).
	var r := Vector3(0, 0, -100)
	var v_rel := Vector3(10, 0, 0) - v_missile
	var a := Guidance.pn_acceleration(r, v_rel, v_missile, Vector3.ZERO, 4.0, 1000.0)
	check(a.x > 0.0, "the command turns toward the line of sight's rotation: %s" % a)
	check_near(a.length(), 4.0 * 50.0 * 0.1, 1e-6, "|a| = N Vc λ̇")
	check_near(a.dot(v_missile), 0.0, 1e-6, "the command is lateral")
	# Augmented: half N times the target's acceleration across the line of sight is added.
	var a_aug := Guidance.pn_acceleration(r, v_rel, v_missile, Vector3(0, 6, 0), 4.0, 1000.0)
	check_near(a_aug.y, 0.5 * 4.0 * 6.0, 1e-6, "augmentation term N/2 · a_T⊥")
	# The cap (turn rate × speed).
	var capped := Guidance.pn_acceleration(r, v_rel, v_missile, Vector3.ZERO, 4.0, 5.0)
	check_near(capped.length(), 5.0, 1e-6, "|a| capped")
	var next: Array = Guidance.step_missile(Vector3.ZERO, v_missile, capped, 0.1)
	check_near((next[1] as Vector3).length(), 50.0, 1e-4, "the step keeps the missile's speed")


func test_closest_approach() -> void:
	check_near(Guidance.closest_approach(Vector3(-5, 1, 0), Vector3(5, 1, 0)), 1.0, 1e-9, "passing by at 1 m")
	check_near(Guidance.closest_approach(Vector3(-5, 0, 0), Vector3(5, 0, 0)), 0.0, 1e-9, "passing through")
	check_near(Guidance.closest_approach(Vector3(3, 4, 0), Vector3(6, 8, 0)), 5.0, 1e-9, "moving away: the start")


## A weaving target (circle plus vertical weave, 25 m/s), a missile fired at its lead point:
## with navigation it hits; flying straight on at the lead point, it misses (the target turns).
func test_navigation_hits_a_maneuvering_target() -> void:
	var with_pn := _chase(4.0)
	var without := _chase(0.0)
	check(with_pn.hit, "N = 4: hit (closest %.2f m after %.2f s)" % [with_pn.closest, with_pn.time])
	check(not without.hit and without.closest > 5.0,
			"N = 0 (no guidance): a clear miss, closest %.2f m" % without.closest)


func _chase(n: float) -> Dictionary:
	var dt := 1.0 / 60.0
	var speed := 55.0
	var radius := 30.0
	var omega := 25.0 / radius
	var target_at := func(t: float) -> Array:
		var th := omega * t
		var p := Vector3(radius * cos(th), 25.0 + 6.0 * sin(3.0 * th), -50.0 + radius * sin(th))
		var v := Vector3(-radius * sin(th), 18.0 * cos(3.0 * th), radius * cos(th)) * omega
		var a := Vector3(-radius * cos(th), -54.0 * sin(3.0 * th), -radius * sin(th)) * omega * omega
		return [p, v, a]
	var tgt: Array = target_at.call(0.0)
	var pos := Vector3.ZERO
	var vel: Vector3 = (Guidance.lead_point(pos, tgt[0], tgt[1], speed) - pos).normalized() * speed
	var closest := INF
	var t := 0.0
	while t < 6.0:
		var accel := Guidance.pn_acceleration(tgt[0] - pos, tgt[1] - vel, vel, tgt[2], n, deg_to_rad(90.0) * speed)
		var before: Vector3 = tgt[0] - pos
		var next: Array = Guidance.step_missile(pos, vel, accel, dt)
		pos = next[0]
		vel = next[1]
		t += dt
		tgt = target_at.call(t)
		var gap := Guidance.closest_approach(before, tgt[0] - pos)
		closest = minf(closest, gap)
		if gap <= 1.5:
			return {"hit": true, "closest": gap, "time": t}
	return {"hit": false, "closest": closest, "time": t}
