"""Run a task with a policy: a checkpoint, the policy shipped with agile, or sinusoidal test actions.

    agile play --task Velocity-G1-History-v0 --num_envs 2 --num_steps 50   # shipped policy
    agile play --task Velocity-T1-v0 --checkpoint logs/rsl_rl/velocity_t1/<run>/model_3000.pt
    agile play --task Velocity-T1-v0 --sinusoidal       # test actions, no policy
    agile play --task Velocity-G1-History-v0 --viewer viser   # browser viewer on http://localhost:8080
    agile play --task Debug-G1-v0        # joint sliders and the mirrored twin, in the browser
    agile play --task PickPlace-G1-Debug-v0 --checkpoint checkpoints/PickPlace-G1-v0_it4450.pt   # a policy, live
    agile play --task MotionTracking-G1-v0 --checkpoint model.pt --num_envs 1 --num_steps 400 \\
        --video squat.mp4 --video_reference env.commands.motion.start_frame=0 env.episode_length_s=8.0

Without --checkpoint the task's shipped policy runs if agile has one (agile/data/policy/), else
sinusoidal test actions. A debug task opens the browser GUI; it plays the shipped policy of the task it debugs
(PickPlace-G1-Debug-v0: PickPlace-G1-v0's) or --checkpoint, and without either its sliders drive it.
Otherwise headless by default. Observation noise and curricula are switched off.

--video renders env 0 into an mp4 (Newton's ray-tracing camera, headless). With --video_reference, for a task
whose command holds a whole-body reference (motion tracking), each frame also shows an orange kinematic copy of
the robot at the reference pose, about 1 m to its right: the robot and what it tracks, side by side.
"""

from __future__ import annotations

import dataclasses
import faulthandler
import math
import signal
import sys
import threading
import time

from agile.run.arguments import command
from agile.run import arguments, task_setup
from agile.errors import AgileError

from agile.run.task_kinds import run_command
from agile.run.policy import inference_cfg

LOCAL_HOST = "127.0.0.1"
"""`agile.gui.viewer.LOCAL_HOST`, named here so that --help does not import the viewer (and torch)."""



def sinusoidal_actions(step: int, step_dt: float, num_envs: int, action_dim: int, device):
    """0.5·sin(2π(0.5 + 0.2·(i mod 5))·t + iπ/dim) on action i: exercises every joint without a policy."""
    import torch

    i = torch.arange(action_dim, device=device, dtype=torch.float32)
    freq_hz = 0.5 + 0.2 * torch.remainder(i, 5)
    t = step * step_dt
    return (0.5 * torch.sin(2 * math.pi * freq_hz * t + i * math.pi / action_dim)).expand(num_envs, -1)


DEFAULT_HEADLESS_STEPS = 1000


@dataclasses.dataclass(frozen=True)
class PlayOptions:
    """Everything `agile play` runs with, for a task of any kind (`agile.run.task_kinds`: the kind's play function takes
    it). `checkpoint` None: the task's shipped policy where agile has one, else sinusoidal test actions (`sinusoidal`:
    those, always); a multi-agent task: its training run folder. `num_steps` None: DEFAULT_HEADLESS_STEPS headless,
    until Ctrl-C with the viewer. `viewer` "viser" | "none" | None (viser for a debug task); `port`, `host`, `follow`:
    the viewer's. `usd`, `video` (`video_size` in pixels, `video_reference`: the command's reference pose beside the
    robot): the rollout recorded. `validate_fallen_states`: the stand-up tasks' fallen-state dataset shown."""
    task: str
    num_envs: int | None = None
    device: str | None = None
    seed: int | None = None
    rnn: str | None = None
    overrides: tuple = ()
    checkpoint: str | None = None
    sinusoidal: bool = False
    num_steps: int | None = None
    viewer: str | None = None
    port: int = 8080
    follow: bool = True
    host: str = LOCAL_HOST
    real_time: bool = False
    usd: str | None = None
    video: str | None = None
    video_size: tuple = (640, 480)
    video_reference: bool = False
    validate_fallen_states: bool = False
    trust_checkpoint: bool = False
    collect_datasets_anew: bool = False


class CtrlC:
    """Ctrl-C (SIGINT) ends the run between two steps: the first one sets `requested`, which the loop reads; a
    second one interrupts at once (KeyboardInterrupt). A KeyboardInterrupt raised wherever the loop happens to be
    can cut a viser or Warp call in half and leave a lock held, and the shutdown then waits on that lock.

    Also `kill -USR1 <pid>` prints every thread's stack (faulthandler): what to send a viewer that stops answering.
    Installed only from the main thread, and not where SIGINT is ignored (a background job's children)."""

    def __init__(self):
        self.requested = False
        self._previous = None
        if threading.current_thread() is threading.main_thread():
            if sys.__stderr__ is not None:
                faulthandler.register(signal.SIGUSR1, file=sys.__stderr__, all_threads=True)
            if signal.getsignal(signal.SIGINT) is not signal.SIG_IGN:
                self._previous = signal.signal(signal.SIGINT, self._handle)

    def _handle(self, signum, frame) -> None:
        if self.requested:
            raise KeyboardInterrupt
        self.requested = True

    def restore(self) -> None:
        if self._previous is not None:
            signal.signal(signal.SIGINT, self._previous)
            self._previous = None


def with_visual_meshes(env_cfg):
    """The viewer draws the robots' visual meshes, which headless runs do not load."""
    import dataclasses

    from agile.sim.scene_cfg import ArticulationCfg

    env_cfg.scene.entities = {name: dataclasses.replace(cfg, parse_visuals=True) if isinstance(cfg, ArticulationCfg)
                              else cfg for name, cfg in env_cfg.scene.entities.items()}
    return env_cfg


def show_fallen_states(env_cfg, task: str) -> None:
    """--validate_fallen_states: every reset from the fallen-state dataset (no standing share), one per second."""
    from agile.tasks.stand_up.fallen_states import reset_from_fallen_dataset
    from agile.rl_env.managers import EventTerm

    resets = [term for term in vars(env_cfg.events).values()
              if isinstance(term, EventTerm) and term.func is reset_from_fallen_dataset]
    if not resets:
        raise AgileError(f"--validate_fallen_states: {task} has no reset event reset_from_fallen_dataset")
    for term in resets:
        term.params["standing_ratio"] = 0.0
    env_cfg.episode_length_s = 1.0


def check_play_options(options: PlayOptions) -> None:
    """Refuse, before anything is built, options that cannot go together (for a task of any kind; the kind's play
    function refuses what it does not take)."""
    if options.video_reference and not options.video:
        raise AgileError("--video_reference draws into the --video mp4: give --video PATH.mp4 too")


@command
def main(argv=None) -> None:
    parser = arguments.new_parser(__doc__)
    arguments.add_common_args(parser)
    parser.add_argument("--checkpoint", default=None, help="RSL-RL checkpoint (model_<it>.pt) to run")
    parser.add_argument("--sinusoidal", action="store_true", help="sinusoidal test actions instead of a policy")
    parser.add_argument("--num_steps", type=int, default=None,
                        help=f"env steps to run (default: {DEFAULT_HEADLESS_STEPS} headless; with the viewer until "
                             "Ctrl-C)")
    parser.add_argument("--viewer", choices=["none", "viser"], default=None,
                        help="viser: browser viewer with reward plot, commands, pause and step (default: viser for "
                             "debug tasks, none otherwise)")
    parser.add_argument("--port", type=int, default=8080, help="viser port")
    parser.add_argument("--no_follow", action="store_true", help="the viewer's camera stays put (it follows env 0 "
                        "by default; a checkbox in the page switches it)")
    parser.add_argument("--host", default=LOCAL_HOST,
                        help=f"address the viewer listens on (default {LOCAL_HOST}: this machine only; from another "
                             "machine use SSH port forwarding, see the README). 0.0.0.0 exposes it to the network")
    parser.add_argument("--real_time", action="store_true", help="slow down to the control rate")
    parser.add_argument("--usd", default=None, metavar="PATH.usd", help="record the rollout as an animated USD stage")
    parser.add_argument("--video", default=None, metavar="PATH.mp4", help="render env 0 headless into an mp4")
    parser.add_argument("--video_size", type=int, nargs=2, default=(640, 480), metavar=("WIDTH", "HEIGHT"),
                        help="--video's frame size in pixels (single-agent tasks)")
    parser.add_argument("--video_reference", action="store_true",
                        help="with --video: draw the command's reference pose (motion tracking) as an orange copy "
                             "of the robot beside it")
    parser.add_argument("--validate_fallen_states", action="store_true",
                        help="stand-up tasks: show the fallen-state dataset: every env starts fallen, a new state "
                             "every second, zero actions (the joints hold where they lie)")
    arguments.add_checkpoint_args(parser)
    args = arguments.parse(parser, argv)
    options = PlayOptions(
        task=args.task, num_envs=args.num_envs, device=args.device, seed=args.seed, rnn=args.rnn,
        overrides=tuple(args.overrides), checkpoint=args.checkpoint, sinusoidal=args.sinusoidal,
        num_steps=args.num_steps, viewer=args.viewer, port=args.port, follow=not args.no_follow, host=args.host,
        real_time=args.real_time, usd=args.usd, video=args.video, video_size=tuple(args.video_size),
        video_reference=args.video_reference, validate_fallen_states=args.validate_fallen_states,
        trust_checkpoint=args.trust_checkpoint, collect_datasets_anew=args.no_cache)
    check_play_options(options)
    run_command("play", options.task, options)


def play_single_agent(options: PlayOptions) -> dict:
    """`agile play` for every kind but multi-agent (`agile.run.task_kinds`): the steps run, the env-steps per second,
    the mean reward per step, and the episodes ended (by failure: `falls`)."""
    import agile.tasks

    if options.viewer not in (None, "none", "viser"):
        raise AgileError(f"viewer must be one of none, viser (or None: viser for a debug task), got {options.viewer!r}")
    debug_task = agile.tasks.task_kind(options.task) == "debug"
    viewer_on = (options.viewer or ("viser" if debug_task else "none")) == "viser"
    num_steps = options.num_steps if options.num_steps is not None else (None if viewer_on else DEFAULT_HEADLESS_STEPS)

    checkpoint, overrides = options.checkpoint, options.overrides
    if options.validate_fallen_states and (checkpoint or options.sinusoidal):
        raise AgileError("--validate_fallen_states shows the dataset with zero actions: without --checkpoint or "
                         "--sinusoidal")
    if checkpoint is None and not options.sinusoidal and not options.validate_fallen_states:
        # a debug task plays the policy of the task it debugs where agile ships one, else its sliders drive it
        checkpoint, overrides = task_setup.shipped_policy(task=options.task, overrides=overrides)
    slider_actions = debug_task and viewer_on and checkpoint is None and not options.sinusoidal
    contents = (task_setup.read_checkpoint(str(checkpoint), options.trust_checkpoint)
                if checkpoint and not options.sinusoidal else None)
    env_cfg, agent_cfg, device = task_setup.load_task(task=options.task, num_envs=options.num_envs,
                                                      device=options.device, seed=options.seed, rnn=options.rnn,
                                                      overrides=overrides)
    if contents is not None:
        task_setup.warn_overrides_not_repeated(contents, {"env": env_cfg}, "play the task it was trained on")
    import torch
    env_cfg = inference_cfg(env_cfg)
    if options.validate_fallen_states:
        show_fallen_states(env_cfg, options.task)
    env = task_setup.make_env(task=options.task, env_cfg=with_visual_meshes(env_cfg) if viewer_on else env_cfg,
                              device=device, collect_datasets_anew=options.collect_datasets_anew)
    policy = task_setup.load_policy(contents, env, agent_cfg) if contents is not None else None

    viewer = sliders = None
    if viewer_on:
        from agile.gui import ActionSliders, BrowserViewer

        viewer = BrowserViewer(env, options.port, options.host, follow=options.follow)
        if slider_actions:
            sliders = ActionSliders(viewer.server, env)
        print(f"[agile] viewer on {viewer.url} (Ctrl-C to stop)")
    source = ("policy " + checkpoint if policy else "the GUI's sliders" if sliders else
              "zero actions" if options.validate_fallen_states else "sinusoidal test actions")
    print(f"[agile] {options.task}: {env.num_envs} envs on {device}, {source}")

    recorder = None
    if options.usd:
        from agile.run.recorders import UsdRecorder

        recorder = UsdRecorder(options.usd, env, num_frames=num_steps or DEFAULT_HEADLESS_STEPS)
    video = None
    if options.video:
        from agile.run.recorders import VideoRecorder

        if options.video_reference:
            from agile.run.reference_view import reference_command

            try:
                reference_command(env)
            except ValueError as err:
                raise AgileError(f"--video_reference: {err}")
        video = VideoRecorder(options.video, env, *options.video_size, reference=options.video_reference)
    obs, _ = env.reset()
    episodes = falls = step = 0
    reward_sum = torch.zeros((), device=env.device)
    wall_start = time.perf_counter()
    ctrl_c = CtrlC()
    try:
        with torch.inference_mode():
            while (num_steps is None or step < num_steps) and not ctrl_c.requested:
                start = time.perf_counter()
                if viewer is not None:
                    if not viewer.is_running():
                        break
                    if viewer.reset_requested or (sliders is not None and sliders.reset_requested):
                        obs, _ = env.reset()
                        viewer.reset_requested = False
                        if sliders is not None:
                            sliders.after_reset()
                    if not viewer.should_step():  # paused: keep answering the page, at 10 Hz
                        viewer.render(env, step * env.step_dt)
                        time.sleep(0.1)
                        continue
                if policy is not None:
                    actions = policy(obs)
                elif sliders is not None:
                    actions = sliders.actions()
                elif options.validate_fallen_states:
                    actions = torch.zeros(env.num_envs, env.action_manager.total_action_dim, device=env.device)
                else:
                    actions = sinusoidal_actions(step, env.step_dt, env.num_envs, env.action_manager.total_action_dim,
                                                 env.device)
                obs, reward, terminated, truncated, _ = env.step(actions)
                step += 1
                reward_sum += reward.mean()
                episodes += int((terminated | truncated).sum())
                falls += int(terminated.sum())
                if recorder is not None:
                    recorder.record(env, step * env.step_dt)
                if video is not None:
                    video.record(env)
                if viewer is not None:
                    viewer.render(env, step * env.step_dt)
                    if sliders is not None:
                        sliders.update()
                if options.real_time or viewer is not None:  # a viewer shows the motion at its real speed
                    time.sleep(max(0.0, env.step_dt - (time.perf_counter() - start)))
    except KeyboardInterrupt:
        pass
    finally:
        ctrl_c.restore()
    if ctrl_c.requested:
        print("[agile] stopped")
    elapsed = time.perf_counter() - wall_start
    played = {"steps": step, "env_steps_per_s": step * env.num_envs / elapsed,
              "mean_reward_per_step": float(reward_sum) / max(step, 1), "episodes": episodes, "falls": falls}
    print(f"[agile] {step} steps in {elapsed:.1f} s ({played['env_steps_per_s']:.0f} env-steps/s); "
          f"mean reward per step {played['mean_reward_per_step']:.4f}; episodes ended {episodes}, by failure {falls}")
    if viewer is not None:
        viewer.close()
    if recorder is not None:
        recorder.close()
        print(f"[agile] USD stage written to {recorder.path}")
    if video is not None:
        video.close()
        print(f"[agile] video ({video.frames} frames) written to {video.path}")
    env.close()
    return played


if __name__ == "__main__":
    main()
