"""`cotsfleet ctl --run-dir DIR ORDER ...`: the operator's live order to a running mission.

``recall|abort|pause|resume VEHICLE|all``, ``add-spot X Y PRIORITY``, ``drop-spot ID``. The
order is signed with the operator's key (``DIR``'s ``credentials/operator``) and put on
``fleet/ctl/order`` through the mission's router (``DIR/run.json``: `run_record`), under the
operator's own bus login or certificate. The launcher numbers it and sends it into the water
from the topside modem (`cotsfleet.mission.order_desk`); this waits for its answers on
``fleet/ctl/order/answer`` (each opened with the run's ring: only the operator's key speaks
there) and prints who acknowledged, until every vehicle the order names has answered or
``--timeout`` wall seconds have passed.

From another host (a ground station elsewhere) there is no run dir and no operator's key:
``cotsfleet ctl --connect tls/HOST:7447 --credentials DIR/ground ORDER ...`` signs with the
``ground`` identity of the mission's credentials (`cotsfleet credentials DIR`), which may put
order requests and hear their answers, nothing else (docs/operator.md, docs/security.md).

Exit codes: 0 every vehicle named acknowledged (or, with ``--timeout 0``, the launcher took
the order), 1 refused or not acknowledged in time, 2 bad input, no running mission or no
router there.
"""

from __future__ import annotations

import argparse
import queue
import re
import secrets
import time
from pathlib import Path

from cotsfleet.errors import UsageError

HELP = "the operator's live order to a running mission (recall, abort, pause, resume, ...)"
USAGE_ORDERS = ("recall|abort|pause|resume VEHICLE|all, add-spot X Y PRIORITY, "
                "drop-spot ID")
ANSWER_WAIT_S = 10.0  # wall seconds for the launcher to take the order
DEFAULT_TIMEOUT_S = 120.0  # wall seconds for the acknowledgements


def add_arguments(p: argparse.ArgumentParser) -> None:
    where = p.add_mutually_exclusive_group(required=True)
    where.add_argument("--run-dir", type=Path, metavar="DIR",
                       help="the running mission's run dir (`cotsfleet run --run-dir`, or the "
                       "one it printed), on the launcher's host")
    where.add_argument("--connect", metavar="ENDPOINT",
                       help="from another host: the mission's router, HOST:PORT or "
                       "tls/HOST:PORT (with --credentials)")
    p.add_argument("--credentials", type=Path, metavar="DIR",
                   help="with --connect: the ground station's credentials directory (DIR/ground "
                   "of `cotsfleet credentials DIR`)")
    p.add_argument("--timeout", type=float, default=DEFAULT_TIMEOUT_S, metavar="S",
                   help=f"wall seconds to wait for the acknowledgements (default "
                   f"{DEFAULT_TIMEOUT_S:g}; 0: only until the launcher takes the order)")
    p.add_argument("order", nargs="+", metavar="ORDER", help=USAGE_ORDERS)


def _order(words: list[str]):
    from fleet_bus.orders import OrderError, parse_words

    try:
        return parse_words(words)
    except OrderError as exc:
        raise UsageError(f"{exc} (orders: {USAGE_ORDERS})") from None


def run(args: argparse.Namespace) -> int:
    if not args.timeout >= 0:
        raise UsageError(f"--timeout must be 0 or more seconds, got {args.timeout:g}")
    if args.run_dir is not None and args.credentials is not None:
        raise UsageError("--credentials goes with --connect; --run-dir finds the operator's "
                         "credentials itself")
    if args.connect is not None and args.credentials is None:
        raise UsageError("--connect needs --credentials DIR/ground (the ground station's "
                         "identity, made by `cotsfleet credentials DIR`)")
    order = _order(args.order)
    if args.connect is not None:
        auth, endpoint, vehicles = _remote(args.connect, args.credentials)
        _known(order, vehicles)
        return _send(auth, endpoint, args.credentials, order, args.timeout)
    from cotsfleet.mission.run_record import NoMission, read_run_record

    try:
        record = read_run_record(args.run_dir)
    except NoMission as exc:
        raise UsageError(str(exc)) from None
    _known(order, record.vehicles)
    return _send(_operator(record), record.endpoint, record.operator_dir, order,
                 args.timeout)


def _known(order, vehicles) -> None:
    from fleet_bus.orders import ALL

    if order.target != ALL and order.target not in vehicles:
        raise UsageError(f"no vehicle {order.target!r} in this mission; it has "
                         f"{', '.join(vehicles)}")


def _operator(record):
    """The operator's identity, of the mission running in ``record``'s run dir."""
    from fleet_bus.credentials import OPERATOR_ID, CredentialsError, load_auth

    try:
        auth = load_auth(record.operator_dir, OPERATOR_ID)
    except CredentialsError as exc:
        raise UsageError(f"the operator's credentials: {exc}") from None
    if auth.run_id != record.run_id:
        raise UsageError(f"{record.operator_dir} is for run {auth.run_id}, the mission is "
                         f"{record.run_id}")
    return auth


def _remote(endpoint: str, creds: Path):
    """The identity in ``creds`` (the ground station's; the operator's is taken too, on its
    own host) and the endpoint on the bus's transport (TLS for credentials made by
    `cotsfleet credentials`); the mission's vehicles are the ring's."""
    from fleet_bus.auth import VEHICLE
    from fleet_bus.credentials import (GROUND_ID, OPERATOR_ID, RING, CredentialsError,
                                       load_auth, load_ring, uses_tls)
    from fleet_bus.session import with_protocol

    if not (creds / RING).is_file():
        raise UsageError(f"--credentials {creds}: no {RING} there, not a process's credentials "
                         "(give DIR/ground of `cotsfleet credentials DIR`)")
    try:
        ring = load_ring(creds)
    except CredentialsError as exc:
        raise UsageError(f"--credentials: {exc}") from None
    auth = None
    for sid in (GROUND_ID, OPERATOR_ID):
        try:
            auth = load_auth(creds, sid)
            break
        except CredentialsError:
            continue
    if auth is None:
        why = ("made before the ground station had an identity: make them again"
               if GROUND_ID not in ring.ring else
               "give the ground station's directory, DIR/ground of `cotsfleet credentials DIR`")
        raise UsageError(f"--credentials {creds} holds neither the ground station's nor the "
                         f"operator's signing key ({why})")
    try:
        endpoint = with_protocol(endpoint, uses_tls(creds))
    except ValueError as exc:
        raise UsageError(f"--connect {exc}") from None
    vehicles = tuple(sid for sid, m in ring.ring.items() if m.role == VEHICLE)
    return auth, endpoint, vehicles


def _send(auth, endpoint: str, creds: Path, order, timeout_s: float) -> int:
    import zenoh

    from fleet_bus import keys, topics
    from fleet_bus.auth import Refused
    from fleet_bus.credentials import OPERATOR_ID, CredentialsError
    from fleet_bus.orders import Answer, encode_request
    from fleet_bus.session import client_config

    try:
        conf = client_config([endpoint], timeout_s=5.0, credentials=creds)
    except CredentialsError as exc:
        raise UsageError(str(exc)) from None
    ref = secrets.token_hex(8)
    answers: queue.Queue[Answer] = queue.Queue(maxsize=256)

    def on_answer(sample: zenoh.Sample) -> None:
        try:  # only the operator's key speaks there; anything else is not the launcher
            signer, payload = auth.open(topics.ORDER_ANSWER.key, sample.payload.to_bytes())
            answer = topics.ORDER_ANSWER.decode(payload)
        except (Refused, ValueError):  # a `TopicError` is a ValueError
            return
        if signer == OPERATOR_ID and answer.ref == ref:
            try:
                answers.put_nowait(answer)
            except queue.Full:
                pass

    try:
        session = zenoh.open(conf)
    except zenoh.ZError as exc:
        # Zenoh's first line, without the place in its Rust source it adds
        why = re.sub(r" at \S+\.rs:\d+\.?$", "", (str(exc).strip() or "no answer").splitlines()[0])
        raise UsageError(f"cannot reach the mission's router at {endpoint}: {why}") from None
    with session:
        sub = session.declare_subscriber(topics.ORDER_ANSWER.key, on_answer)
        try:
            time.sleep(0.2)  # the subscription reaches the router before the request
            session.put(keys.ORDER_REQUEST,
                        auth.seal(keys.ORDER_REQUEST, encode_request(order, ref)))
            return _wait(answers, order, timeout_s)
        finally:
            sub.undeclare()


def _wait(answers, order, timeout_s: float) -> int:
    """Print the launcher's answers; the exit code (module docstring)."""
    import queue as q

    try:
        first = answers.get(timeout=ANSWER_WAIT_S)
    except q.Empty:
        print(f"cotsfleet ctl: the launcher did not take {order.describe()} within "
              f"{ANSWER_WAIT_S:g} s (is the mission still running?)")
        return 1
    if first.error:
        print(f"cotsfleet ctl: refused by the launcher: {first.error}")
        return 1
    print(f"order #{first.seq} {first.order}: sent from the topside at mission time "
          f"{first.issued_s:.0f} s, for {', '.join(first.targets)}")
    if timeout_s == 0:
        return 0
    deadline, last, told = time.monotonic() + timeout_s, first, set()
    while True:
        for vid, t in sorted(last.acked.items()):
            if vid not in told:
                told.add(vid)
                print(f"  {vid} acknowledged (heard by the topside at {t:.0f} s)")
        for vid, why in sorted(last.refused.items()):
            if vid not in told:
                told.add(vid)
                print(f"  {vid} refused it: {why}")
        waiting = [v for v in last.targets if v not in told]
        if not waiting:
            return 1 if last.refused else 0
        left = deadline - time.monotonic()
        if left <= 0:
            print(f"cotsfleet ctl: no acknowledgement from {', '.join(waiting)} within "
                  f"{timeout_s:g} s (the topside resends until they answer or the order is "
                  "stale)")
            return 1
        try:
            last = answers.get(timeout=left)
        except q.Empty:
            continue
