// Arrow keys steer the vessel through /cmd_wrench (geometry_msgs/msg/Wrench): up/down push
// forward/back (force.x, N), left/right turn to port/starboard (torque.z, N·m, counter-clockwise
// positive). The command is re-sent while keys are held and zeroed when they are released.
import { topic } from "./catalogue.js";

const MAX_SURGE_FORCE_N = 4000; // simulator VesselConfig.max_surge_force_n (the actuator limit)
const MAX_YAW_MOMENT_NM = 6000; // simulator VesselConfig.max_yaw_moment_nm
const REPEAT_MS = 100;
// Fractions of those limits per key. The full yaw moment spins the hull at ~1.3 rad/s (IMU
// panel), far too quick to steer by hand; a third of it turns at a helmsman's pace.
const KEYS = {
  ArrowUp: [1, 0],
  ArrowDown: [-0.5, 0],
  ArrowLeft: [0, 0.3],
  ArrowRight: [0, -0.3],
};

export class KeyboardSteering {
  constructor(target, connection, onCommand) {
    this.connection = connection;
    this.onCommand = onCommand;
    this.held = new Set();
    this.timer = null;
    target.addEventListener("keydown", (event) => this.#down(event));
    target.addEventListener("keyup", (event) => this.#up(event));
    target.addEventListener("blur", () => this.#release());
  }

  /** {surge_n, yaw_nm} of the keys held now. */
  command() {
    let [surge, yaw] = [0, 0];
    for (const key of this.held) {
      surge += KEYS[key][0];
      yaw += KEYS[key][1];
    }
    return { surge_n: clamp(surge) * MAX_SURGE_FORCE_N, yaw_nm: clamp(yaw) * MAX_YAW_MOMENT_NM };
  }

  #down(event) {
    if (event.key === " ") {
      event.preventDefault();
      this.#release();
      return;
    }
    if (!(event.key in KEYS)) return;
    event.preventDefault();
    if (this.held.has(event.key)) return; // auto-repeat: the timer already re-sends
    this.held.add(event.key);
    this.#send();
    this.timer ??= setInterval(() => this.#send(), REPEAT_MS);
  }

  #up(event) {
    if (!this.held.delete(event.key)) return;
    this.#send();
    if (this.held.size === 0) this.#stopRepeating();
  }

  #release() {
    this.held.clear();
    this.#send();
    this.#stopRepeating();
  }

  #stopRepeating() {
    clearInterval(this.timer);
    this.timer = null;
  }

  #send() {
    const { surge_n, yaw_nm } = this.command();
    const { name, type } = topic("cmd_wrench");
    this.connection.publish(name, type, {
      force: { x: surge_n, y: 0, z: 0 },
      torque: { x: 0, y: 0, z: yaw_nm },
    });
    this.onCommand(surge_n, yaw_nm, this.held.size > 0);
  }
}

function clamp(value) {
  return Math.max(-1, Math.min(1, value));
}
