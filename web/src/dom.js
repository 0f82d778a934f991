// What the views and controls share of the document: element lookup and the in-page
// confirmation (window.confirm blocks and cannot be styled or tested).
export const $ = (id) => document.getElementById(id);

let confirmResolver = null;

// Whether the confirmation is open (Escape answers it, other keys wait).
export const confirmOpen = () => confirmResolver !== null;
export const answerConfirm = (answer) => confirmResolver?.(answer);

export function confirmAction(text, okLabel) {
  const dialog = $('confirm');
  $('confirm-text').textContent = text;
  $('confirm-ok').textContent = okLabel;
  dialog.hidden = false;
  $('confirm-ok').focus();
  return new Promise((resolve) => {
    const done = (answer) => {
      dialog.hidden = true;
      $('confirm-ok').onclick = $('confirm-cancel').onclick = null;
      confirmResolver = null;
      resolve(answer);
    };
    confirmResolver = done;
    $('confirm-ok').onclick = () => done(true);
    $('confirm-cancel').onclick = () => done(false);
  });
}
