"""The operator page in a real headless Chromium (Playwright driving Debian's ``chromium``).

The page loads and shows the service ``ok``, the library's card with its preview, a garment
registered through the form appears in the library (and in ``GET /models``), a bad name
shows the service's own message without adding a card, results posted by a client show up
by the page's polling with their overlay images, and the live view says there is no camera
until the service has a source, then shows camera 1 tracking the chosen model. A full-page
screenshot is written to ``build/operator_page.png`` for a person to look at.

Skipped, saying so, only when no browser can be had: ``PHOTOMODEL_CHROMIUM`` names the
executable (a wrong value skips rather than falling back), else ``chromium``,
``chromium-browser`` or ``google-chrome`` on the PATH; ``.ci/run`` installs Debian's
``chromium`` when absent.
"""

from __future__ import annotations

import os
import re
import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from photomodel.errors import InputError
from photomodel.library import check_model_name

_INSTALL_HINT = "install Debian's chromium package (apt-get install -y chromium)"
_BROWSER_NAMES = ("chromium", "chromium-browser", "google-chrome")
_SCREENSHOT = Path(__file__).resolve().parents[2] / "build" / "operator_page.png"
_POLL_TIMEOUT_MS = 10_000      # the page polls every 2 s; a locate takes about a second
_REGISTER_TIMEOUT_MS = 60_000  # building a photo-model on a slow CI machine


def find_chromium(environ: dict[str, str] | None = None) -> tuple[str | None, str]:
    """The Chromium executable to drive and, when there is none, why not.

    ``PHOTOMODEL_CHROMIUM`` wins when set (a path or a name on the PATH); a value that is
    not an executable is reported, not replaced by another browser.
    """
    env = os.environ if environ is None else environ
    explicit = env.get("PHOTOMODEL_CHROMIUM", "").strip()
    if explicit:
        found = shutil.which(explicit)
        if found is None:
            return None, (f"no Chromium: PHOTOMODEL_CHROMIUM={explicit!r} is not an executable; "
                          f"unset it or {_INSTALL_HINT}")
        return found, ""
    for name in _BROWSER_NAMES:
        found = shutil.which(name)
        if found is not None:
            return found, ""
    return None, f"no Chromium ({', '.join(_BROWSER_NAMES)} not on the PATH): {_INSTALL_HINT}"


def test_find_chromium_explicit_bad_value_is_reported(tmp_path: Path) -> None:
    not_executable = tmp_path / "chromium"
    not_executable.write_text("")
    for value in ("/nonexistent/chromium", str(not_executable)):
        path, why = find_chromium({"PHOTOMODEL_CHROMIUM": value})
        assert path is None
        assert why.startswith("no Chromium") and repr(value) in why
        assert "apt-get install -y chromium" in why


def test_find_chromium_explicit_executable_wins(tmp_path: Path) -> None:
    fake = tmp_path / "my-chrome"
    fake.write_text("#!/bin/sh\n")
    fake.chmod(0o755)
    assert find_chromium({"PHOTOMODEL_CHROMIUM": str(fake)}) == (str(fake), "")


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    executable, why = find_chromium()
    if executable is None:
        pytest.skip(why)
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("no Chromium driver: the Python package playwright is not installed "
                    "(pip install -e '.[dev]')")
    with sync_playwright() as p:
        # --no-sandbox: CI runs as root, where Chromium's sandbox refuses to start
        launched = p.chromium.launch(executable_path=executable,
                                     args=["--no-sandbox", "--disable-dev-shm-usage"])
        try:
            yield launched
        finally:
            launched.close()


@pytest.fixture
def page(browser: Any, service: Any) -> Iterator[Any]:
    """A fresh page on the operator page. An uncaught script error fails the test, and so
    does any answer of 400 or more other than a refused ``POST /models`` (a wrong path in
    the page, say)."""
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    opened = context.new_page()
    errors: list[str] = []
    refusal_expected = ("POST", service.url + "/models")

    def on_response(response: Any) -> None:
        request = response.request
        if response.status >= 400 and (request.method, response.url) != refusal_expected:
            errors.append(f"{request.method} {response.url}: {response.status}")

    opened.on("pageerror", lambda exc: errors.append(str(exc)))
    opened.on("response", on_response)
    opened.goto(service.url + "/")
    try:
        yield opened
    finally:
        context.close()
    assert errors == [], f"the page raised or was refused: {errors}"


def _image_loaded(page: Any, selector: str) -> None:
    """Wait until the <img> at ``selector`` has finished loading, then require pixels."""
    img = page.locator(selector)
    img.scroll_into_view_if_needed()
    img.evaluate("i => i.complete || new Promise(r => { i.onload = i.onerror = r; })")
    width = img.evaluate("i => i.naturalWidth")
    assert width > 0, f"{selector} did not load ({img.get_attribute('src')})"


def test_page_loads_with_status_and_library(page: Any, service: Any) -> None:
    from playwright.sync_api import expect

    expect(page).to_have_title("photomodel cell")
    expect(page.locator("#status")).to_have_text("ok")
    expect(page.locator("#status")).to_have_class("badge ok")
    card = page.locator('.card[data-model="No.3"]')
    expect(card).to_be_visible()
    expect(card.locator(".name")).to_have_text("No.3")
    expect(card).to_contain_text(" mm")
    _image_loaded(page, '.card[data-model="No.3"] img')
    entry = next(m for m in httpx.get(service.url + "/models").json() if m["name"] == "No.3")
    expect(card.locator(".swatch")).to_have_count(len(entry["colours"]))
    assert card.locator(".swatch").first.get_attribute("title").startswith(
        entry["colours"][0][0])

    page.set_viewport_size({"width": 360, "height": 800})   # a phone: nothing sticks out
    overflow = page.evaluate("document.documentElement.scrollWidth - window.innerWidth")
    assert overflow <= 0, f"the page is {overflow} px wider than a 360 px screen"


def test_register_through_the_form(page: Any, service: Any, cell_data: Any) -> None:
    from playwright.sync_api import expect

    photo, background = cell_data.photos("No.5")
    form = page.locator("#register")
    expect(page.locator('.card[data-model="No.3"]')).to_be_visible()   # library drawn
    form.locator('input[name="name"]').fill("No.5")
    form.locator('input[name="photo"]').set_input_files(photo)
    form.locator('input[name="background"]').set_input_files(background)
    form.locator('button[type="submit"]').click()

    status = page.locator("#register-status")
    expect(status).to_contain_text("registered No.5", timeout=_REGISTER_TIMEOUT_MS)
    expect(status).not_to_have_class("error")
    expect(form.locator('input[name="name"]')).to_have_value("")         # form reset
    expect(form.locator('button[type="submit"]')).to_be_enabled()
    expect(page.locator('.card[data-model="No.5"]')).to_be_visible()
    _image_loaded(page, '.card[data-model="No.5"] img')

    names = [m["name"] for m in httpx.get(service.url + "/models").json()]
    assert "No.5" in names and "No.3" in names


def test_form_error_shows_the_services_message(page: Any, cell_data: Any) -> None:
    from playwright.sync_api import expect

    with pytest.raises(InputError) as refused:
        check_model_name("bad/name", "name")
    photo, background = cell_data.photos("No.5")
    cards = page.locator(".card")
    expect(page.locator('.card[data-model="No.3"]')).to_be_visible()
    before = cards.count()
    form = page.locator("#register")
    form.locator('input[name="name"]').fill("bad/name")
    form.locator('input[name="photo"]').set_input_files(photo)
    form.locator('input[name="background"]').set_input_files(background)
    form.locator('button[type="submit"]').click()

    status = page.locator("#register-status")
    expect(status).to_have_class("error", timeout=_REGISTER_TIMEOUT_MS)
    expect(status).to_have_text(str(refused.value))
    expect(form.locator('input[name="name"]')).to_have_value("bad/name")  # kept to correct
    expect(cards).to_have_count(before)


def test_results_show_with_their_overlays(page: Any, service: Any, cell_data: Any) -> None:
    from playwright.sync_api import expect

    expect(page.locator("#status")).to_have_text("ok")
    scene = cell_data.scene_of("No.3")
    ids = []
    for endpoint, fields in (("/locate", {"model": "No.3", "seed": "1"}),
                             ("/identify", {"seed": "1"})):
        files = {"right": (scene / "right.png").read_bytes(),
                 "left": (scene / "left.png").read_bytes()}
        answer = httpx.post(service.url + endpoint, files=files, data=fields, timeout=120)
        assert answer.status_code == 200, answer.text
        ids.append(answer.json()["id"])

    for rid in ids:      # the page finds them by its own polling
        expect(page.locator(f'.result[data-result="{rid}"]')).to_be_visible(
            timeout=_POLL_TIMEOUT_MS)
    located, identified = (page.locator(f'.result[data-result="{rid}"]') for rid in ids)
    expect(located).to_contain_text("locate · No.3")
    expect(identified).to_contain_text("identify")
    expect(page.locator("#results-empty")).to_be_hidden()
    for rid in ids:
        _image_loaded(page, f'.result[data-result="{rid}"] img')
    expect(page.locator("#latency rect").first).to_be_attached()

    _SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
    page.evaluate("window.scrollTo(0, 0)")
    page.screenshot(path=str(_SCREENSHOT), full_page=True)


def test_live_view_shows_the_camera_with_the_tracked_model(page: Any, service: Any,
                                                           cell_data: Any, tmp_path: Path
                                                           ) -> None:
    import json

    from playwright.sync_api import expect

    expect(page.locator("#live-status")).to_have_text("no camera")      # none yet
    expect(page.locator("#live-none")).to_be_visible()
    expect(page.locator("#live")).to_be_hidden()
    sequence = tmp_path / "seq"
    shutil.copytree(cell_data.scene_of("No.3"), sequence / "000000")
    (sequence / "meta.json").write_text(json.dumps({"fps": 10}))
    cell = service.cell
    cell.attach_source(f"replay:{sequence}")
    try:
        expect(page.locator("#live")).to_be_visible(timeout=_POLL_TIMEOUT_MS)
        expect(page.locator('#live-model option[value="No.3"]')).to_be_attached()
        page.locator("#live-model").select_option("No.3")
        expect(page.locator("#live-status")).to_contain_text("No.3: track",
                                                             timeout=_POLL_TIMEOUT_MS)
        expect(page.locator("#live")).to_have_attribute("src", re.compile("model=No.3"))
        _image_loaded(page, "#live")
        page.goto("about:blank")          # no more pictures asked for once the source goes
    finally:
        link, cell.source = cell.source, None
        link.close()


_ADMIN, _CONTROLLER = "page-admin-token-0123456", "page-controller-token-0123"


@pytest.fixture(scope="module")
def guarded(cell_data: Any, tmp_path_factory: pytest.TempPathFactory) -> Iterator[Any]:
    """A warmed service with an admin and a controller token (a browser logs in)."""
    from photomodel.service import CellService, ServiceConfig, ServiceThread

    root = tmp_path_factory.mktemp("guarded")
    library = root / "library"
    shutil.copytree(cell_data.library, library)
    tokens = root / "tokens.txt"
    tokens.write_text(f"admin {_ADMIN} alice\ncontroller {_CONTROLLER} plc-7\n")
    cell = CellService(ServiceConfig(stereo=cell_data.stereo, models=library,
                                     camera=cell_data.camera, token_file=tokens))
    with ServiceThread(cell) as running:
        running.wait_ready()
        yield running
    cell.close()


def _log_in(browser: Any, url: str, token: str) -> tuple[Any, Any]:
    context = browser.new_context(viewport={"width": 1280, "height": 900})
    opened = context.new_page()
    opened.goto(url + "/")
    assert opened.url.endswith("/login")
    opened.locator('input[name="token"]').fill(token)
    opened.locator('button[type="submit"]').click()
    return context, opened


def test_an_admin_logs_in_changes_the_library_and_logs_out(browser: Any, guarded: Any,
                                                           cell_data: Any) -> None:
    from playwright.sync_api import expect

    context, page = _log_in(browser, guarded.url, _ADMIN)
    try:
        expect(page.locator("#who")).to_have_text("alice (admin)")
        expect(page.locator("#register-section")).to_be_visible()
        photo, background = cell_data.photos("No.5")
        form = page.locator("#register")
        form.locator('input[name="name"]').fill("No.5")
        form.locator('input[name="photo"]').set_input_files(photo)
        form.locator('input[name="background"]').set_input_files(background)
        form.locator('button[type="submit"]').click()        # carries the CSRF token
        expect(page.locator("#register-status")).to_contain_text(
            "registered No.5", timeout=_REGISTER_TIMEOUT_MS)
        page.on("dialog", lambda dialog: dialog.accept())
        page.locator('.card[data-model="No.5"] button.danger').click()
        expect(page.locator('.card[data-model="No.5"]')).to_have_count(0,
                                                                        timeout=_POLL_TIMEOUT_MS)
        page.locator("#logout").click()
        expect(page).to_have_url(re.compile(r"/login$"))
        assert page.context.request.get(guarded.url + "/health").status == 401
    finally:
        context.close()


def test_a_controller_sees_no_library_changes(browser: Any, guarded: Any) -> None:
    from playwright.sync_api import expect

    context, page = _log_in(browser, guarded.url, _CONTROLLER)
    try:
        expect(page.locator("#who")).to_have_text("plc-7 (controller)")
        expect(page.locator('.card[data-model="No.3"]')).to_be_visible()
        expect(page.locator("#register-section")).to_be_hidden()
        expect(page.locator('.card[data-model="No.3"] button.danger')).to_be_hidden()
        _SCREENSHOT.parent.mkdir(parents=True, exist_ok=True)
        page.screenshot(path=str(_SCREENSHOT.with_name("operator_page_controller.png")))
    finally:
        context.close()
