"""The guards on their own, on fake clocks: the token-bucket rate limiter, the circuit breaker and the result cache."""

import threading
import time

import pytest

from tools import BreakerPolicy, CircuitBreaker, RateLimit, RateLimiter, ToolDefinitionError
from tools.cache import ResultCache, canonical_key

from .conftest import FakeClock


def state(breaker: CircuitBreaker) -> str:
    return breaker.state  # as a plain str: mypy would narrow the property across asserts


# rate limits ------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("text", "per_s", "burst"),
    [
        ("10/s", 10.0, 10),
        ("30/min", 0.5, 30),
        ("30/m", 0.5, 30),
        ("500/h", 500 / 3600, 500),
        ("1000/day", 1000 / 86400, 1000),
        ("2.5/s", 2.5, 3),
        ("0.5/s", 0.5, 1),
        ("5 / seconds", 5.0, 5),
        ("6/minutes", 0.1, 6),
        ("24/hours", 24 / 3600, 24),
        ("7/SEC", 7.0, 7),
    ],
)
def test_rate_limit_parse(text: str, per_s: float, burst: float) -> None:
    limit = RateLimit.parse(text)
    assert limit.per_s == pytest.approx(per_s) and limit.burst == burst and limit.text == text.strip()


def test_rate_limit_in_milliseconds() -> None:
    assert RateLimit.parse("10/ms").per_s == pytest.approx(10_000)


def test_rate_limit_burst_override() -> None:
    assert RateLimit.parse("20/s", 5).burst == 5
    assert RateLimit.parse("1/h", 10).burst == 10


@pytest.mark.parametrize("text", ["fast", "10", "10/fortnight", "0/s", "-1/s", "/s", "ten/s", "10/s/s", ""])
def test_bad_rate_limits(text: str) -> None:
    with pytest.raises(ToolDefinitionError, match="rate limit"):
        RateLimit.parse(text)


def test_bad_burst() -> None:
    with pytest.raises(ToolDefinitionError, match="burst must be at least 1"):
        RateLimit.parse("10/s", 0)


# the rate limiter -------------------------------------------------------------------------------------------------
def test_burst_then_refill(clock: FakeClock) -> None:
    limiter = RateLimiter(RateLimit.parse("2/s", 3), None, clock=clock)
    assert [limiter.acquire("a")[0] for _ in range(4)] == [True, True, True, False]
    admitted, wait = limiter.acquire("a")
    assert not admitted and wait == pytest.approx(0.5)
    clock.advance(0.25)
    admitted, wait = limiter.acquire("a")
    assert not admitted and wait == pytest.approx(0.25)
    clock.advance(0.25)
    assert limiter.acquire("a") == (True, 0.0)
    assert limiter.acquire("a")[0] is False


def test_an_idle_bucket_holds_at_most_the_burst(clock: FakeClock) -> None:
    limiter = RateLimiter(RateLimit.parse("10/s", 4), None, clock=clock)
    clock.advance(3600)
    assert limiter.available() == 4
    assert sum(limiter.acquire("a")[0] for _ in range(10)) == 4


def test_both_buckets_must_hold_a_token(clock: FakeClock) -> None:
    limiter = RateLimiter(RateLimit.parse("3/s"), RateLimit.parse("1/s"), clock=clock)
    assert limiter.acquire("alice")[0]
    assert limiter.available() == 2
    admitted, wait = limiter.acquire("alice")  # the tool has tokens, alice has none
    assert not admitted and wait == pytest.approx(1.0)
    assert limiter.available() == 2  # a refused call takes no token from the other bucket
    assert limiter.acquire("bob")[0] and limiter.acquire("carol")[0]
    admitted, wait = limiter.acquire("dave")  # dave has a token, the tool has none
    assert not admitted and wait == pytest.approx(1 / 3)


def test_per_caller_only(clock: FakeClock) -> None:
    limiter = RateLimiter(None, RateLimit.parse("2/min"), clock=clock)
    assert limiter.available() is None
    assert [limiter.acquire("a")[0] for _ in range(3)] == [True, True, False]
    assert [limiter.acquire("b")[0] for _ in range(3)] == [True, True, False]
    clock.advance(30)
    assert limiter.acquire("a")[0] and not limiter.acquire("a")[0]


def test_least_recently_used_caller_buckets_are_dropped(clock: FakeClock, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(RateLimiter, "MAX_CALLERS", 2)
    limiter = RateLimiter(None, RateLimit.parse("1/h"), clock=clock)
    assert limiter.acquire("a")[0] and limiter.acquire("b")[0]
    assert not limiter.acquire("a")[0]  # a is now the most recent
    assert limiter.acquire("c")[0]  # b is dropped
    assert not limiter.acquire("a")[0]
    assert limiter.acquire("b")[0]  # a dropped bucket comes back full


def test_limiter_admission_under_8_threads_on_a_moving_fake_clock(clock: FakeClock) -> None:
    limiter = RateLimiter(RateLimit.parse("20/s", 5), None, clock=clock)
    admitted = [0] * 8
    stop = threading.Event()

    def work(index: int) -> None:
        while not stop.is_set():
            if limiter.acquire(f"c{index}")[0]:
                admitted[index] += 1
            time.sleep(0.0001)  # let the clock thread in

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    elapsed = 0.0
    for _ in range(100):
        time.sleep(0.0005)
        clock.advance(0.01)
        elapsed += 0.01
    stop.set()
    for thread in threads:
        thread.join(5)
    assert 5 <= sum(admitted) <= 20 * elapsed + 5 + 1e-9
    assert sum(admitted) > 5  # the refill reached the threads


def test_limiter_exact_admission_under_8_threads_on_a_frozen_clock(clock: FakeClock) -> None:
    limiter = RateLimiter(RateLimit.parse("20/s", 5), RateLimit.parse("1/s", 2), clock=clock)
    admitted: list[int] = [0] * 8
    barrier = threading.Barrier(8)

    def work(index: int) -> None:
        barrier.wait()
        for _ in range(50):
            admitted[index] += limiter.acquire(f"c{index % 4}")[0]

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(5)
    assert sum(admitted) == 5  # the tool's burst, and no caller over its own burst of 2


# the circuit breaker ----------------------------------------------------------------------------------------------
def test_breaker_opens_at_the_threshold_and_probes_once(clock: FakeClock) -> None:
    breaker = CircuitBreaker(BreakerPolicy(failure_threshold=3, reset_timeout_s=10), clock=clock)
    for _ in range(2):
        assert breaker.allow() == (True, 0.0)
        breaker.failure()
    assert state(breaker) == "closed" and breaker.consecutive_failures == 2
    breaker.failure()
    assert state(breaker) == "open"
    assert breaker.allow() == (False, 10.0)
    clock.advance(9.5)
    allowed, wait = breaker.allow()
    assert not allowed and wait == pytest.approx(0.5)
    clock.advance(0.5)
    assert state(breaker) == "half_open"
    assert breaker.allow() == (True, 0.0)  # the probe
    assert breaker.allow() == (False, 1.0)  # only one; its verdict comes soon, so: ask again in a second
    breaker.success()
    assert state(breaker) == "closed" and breaker.consecutive_failures == 0
    assert breaker.transitions == [(1000.0, "open"), (1010.0, "closed")]


def test_a_failed_probe_reopens_for_a_full_reset_timeout(clock: FakeClock) -> None:
    breaker = CircuitBreaker(BreakerPolicy(failure_threshold=1, reset_timeout_s=5), clock=clock)
    breaker.failure()
    clock.advance(5)
    assert breaker.allow()[0]
    breaker.failure()
    assert state(breaker) == "open" and breaker.allow() == (False, 5.0)
    clock.advance(5)
    assert state(breaker) == "half_open"


def test_release_frees_the_probe_slot(clock: FakeClock) -> None:
    breaker = CircuitBreaker(BreakerPolicy(failure_threshold=1, reset_timeout_s=5), clock=clock)
    breaker.failure()
    clock.advance(5)
    assert breaker.allow()[0]
    breaker.release()  # the probe told nothing about the tool
    assert state(breaker) == "half_open"
    assert breaker.allow()[0]


def test_successes_reset_the_failure_count(clock: FakeClock) -> None:
    breaker = CircuitBreaker(BreakerPolicy(failure_threshold=2), clock=clock)
    for _ in range(5):
        breaker.failure()
        breaker.success()
    assert state(breaker) == "closed" and breaker.transitions == []


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"failure_threshold": 0}, "failure_threshold must be at least 1"),
        ({"reset_timeout_s": 0}, "reset_timeout_s must be positive"),
    ],
)
def test_bad_breaker_policies(options: dict[str, float], message: str) -> None:
    with pytest.raises(ToolDefinitionError, match=message):
        BreakerPolicy(**options)  # type: ignore[arg-type]


def test_breaker_lets_exactly_one_probe_through_8_threads(clock: FakeClock) -> None:
    breaker = CircuitBreaker(BreakerPolicy(failure_threshold=1, reset_timeout_s=1), clock=clock)
    breaker.failure()
    clock.advance(1)
    allowed: list[bool] = []
    lock = threading.Lock()
    barrier = threading.Barrier(8)

    def work() -> None:
        barrier.wait()
        for _ in range(20):
            ok = breaker.allow()[0]
            with lock:
                allowed.append(ok)

    threads = [threading.Thread(target=work) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(5)
    assert allowed.count(True) == 1 and len(allowed) == 160


def test_breaker_counts_every_failure_under_8_threads(clock: FakeClock) -> None:
    breaker = CircuitBreaker(BreakerPolicy(failure_threshold=800), clock=clock)
    barrier = threading.Barrier(8)

    def work() -> None:
        barrier.wait()
        for _ in range(100):
            breaker.failure()

    threads = [threading.Thread(target=work) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(5)
    assert breaker.consecutive_failures == 800 and state(breaker) == "open"
    assert breaker.transitions == [(1000.0, "open")]  # opened once, by the 800th failure


# the result cache -------------------------------------------------------------------------------------------------
def test_canonical_key_ignores_key_order() -> None:
    assert canonical_key({"b": 1, "a": {"y": [1, 2], "x": None}}) == canonical_key(
        {"a": {"x": None, "y": [1, 2]}, "b": 1}
    )
    assert canonical_key({"a": [1, 2]}) != canonical_key({"a": [2, 1]})
    assert canonical_key({"a": 1}) != canonical_key({"a": "1"})
    assert canonical_key({"place": "Mina"}) != canonical_key({"place": "Mína"})


def test_cache_ttl(clock: FakeClock) -> None:
    cache = ResultCache(10, clock=clock)
    assert cache.get({"a": 1}) == (False, None)
    cache.put({"a": 1}, {"wind": 4})
    clock.advance(9.99)
    assert cache.get({"a": 1}) == (True, {"wind": 4})
    clock.advance(0.01)
    assert cache.get({"a": 1}) == (False, None)
    assert len(cache) == 0  # the expired entry is dropped
    assert (cache.hits, cache.misses) == (1, 2)


def test_cache_keeps_falsy_values(clock: FakeClock) -> None:
    cache = ResultCache(10, clock=clock)
    cache.put({"q": "empty"}, None)
    cache.put({"q": "zero"}, 0)
    assert cache.get({"q": "empty"}) == (True, None)
    assert cache.get({"q": "zero"}) == (True, 0)


def test_cache_size_bound_drops_least_recently_used(clock: FakeClock) -> None:
    cache = ResultCache(60, max_entries=2, clock=clock)
    cache.put({"k": 1}, "one")
    cache.put({"k": 2}, "two")
    assert cache.get({"k": 1})[0]  # 1 is now the most recent
    cache.put({"k": 3}, "three")
    assert cache.get({"k": 2}) == (False, None)
    assert cache.get({"k": 1}) == (True, "one") and cache.get({"k": 3}) == (True, "three")
    cache.clear()
    assert len(cache) == 0 and cache.get({"k": 1})[0] is False


def test_cache_under_8_threads(clock: FakeClock) -> None:
    cache = ResultCache(60, max_entries=16, clock=clock)
    wrong: list[tuple[int, object]] = []
    barrier = threading.Barrier(8)

    def work(index: int) -> None:
        barrier.wait()
        for i in range(200):
            key = (i * 7 + index) % 24
            hit, value = cache.get({"k": key})
            if hit and value != key * key:
                wrong.append((key, value))
            if not hit:
                cache.put({"k": key}, key * key)

    threads = [threading.Thread(target=work, args=(i,)) for i in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join(5)
    assert wrong == [] and len(cache) <= 16
    assert cache.hits + cache.misses == 1600 and cache.hits > 0


def test_a_call_let_through_while_closed_does_not_free_the_probe_slot_later(clock: FakeClock) -> None:
    breaker = CircuitBreaker(BreakerPolicy(failure_threshold=1, reset_timeout_s=10), clock=clock)
    old = breaker.admit()  # admitted while closed; it will end without a verdict, much later
    assert old == (True, 0.0, False)
    breaker.failure()  # another call fails: open
    clock.advance(10)
    assert breaker.admit() == (True, 0.0, True)  # the probe
    breaker.release(probe=old[2])  # the old call ends: it was not the probe
    assert breaker.allow()[0] is False  # so still only one probe out
    breaker.release(probe=True)  # the probe ends without a verdict
    assert breaker.allow()[0] is True
